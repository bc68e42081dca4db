"""`block3d`: the paper's 3D check, a coupled elastic block sheared slowly into a known field."""
from orchestrator.commands._options import add_out, add_weighting

NAME = "block3d"
HELP = ("3D check (paper §2): coupled YADE/FE block under a slow simple shear; error of the "
        "bridging spheres' displacements and rotations with and without rotation coupling")

CASES = (("full", 1.0), ("diagonal", 35.0))


def configure(p):
    p.add_argument("--gamma", type=float, default=1e-4, help="shear strain amplitude (default 1e-4)")
    p.add_argument("--ramp-steps", type=int, default=600, help="steps of the smooth ramp (default 600)")
    p.add_argument("--hold-steps", type=int, default=400,
                   help="steps held at full load, over which the answer is averaged (default 400)")
    p.add_argument("--layers", type=int, default=2, help="bridging layers (default 2)")
    p.add_argument("--radius", type=float, default=0.003,
                   help="sphere radius in m (default 0.003: the block is 20 radii wide)")
    add_weighting(p, "nodal")
    add_out(p, "results folder")


def run(args):
    from cases.block3d import BlockSpec, ShearCheck, run_shear_check
    from common.files import write_json, write_text
    from orchestrator.run.folder import prepare_out
    check = ShearCheck(gamma=args.gamma, ramp_steps=args.ramp_steps, hold_steps=args.hold_steps)
    specs = [BlockSpec(variant=v, relaxation=r, rotations=rot, layers=args.layers,
                       weighting=args.weighting, radius=args.radius)
             for v, r in CASES for rot in (True, False)]
    out = prepare_out(args.out, args.force)
    rows, runs = [], []
    for spec in specs:
        result = run_shear_check(spec, check)
        runs.append((spec, result))
        e = result["errors"]
        rows.append({"variant": spec.variant, "relaxation": spec.relaxation,
                     "rotations_coupled": spec.rotations, **{
                         f"{where}_{what}": e[where][what] for where in e
                         for what in ("displacement", "rotation")},
                     "bridging_spheres": e["bridging"]["spheres"],
                     "de_zone_spheres": e["de_zone"]["spheres"], "dt": result["dt"]})
        print(f"{spec.variant} r={spec.relaxation:g} rotations {'on ' if spec.rotations else 'off'}: "
              f"bridging spheres: displacement {100 * rows[-1]['bridging_displacement']:.2f} %, "
              f"rotation {100 * rows[-1]['bridging_rotation']:.1f} %; DE zone: "
              f"{100 * rows[-1]['de_zone_displacement']:.2f} %, "
              f"{100 * rows[-1]['de_zone_rotation']:.1f} %")
    write_json(out / "check.json", {"check": vars(check), "layers": args.layers,
                                    "radius": args.radius,
                                    "weighting": args.weighting, "rows": rows})
    write_text(out / "table.md", _table(rows))
    _plot(out / "block3d.png", runs)
    print(f"results in {out}")
    return 0


def _table(rows):
    lines = ["| coupling | rotations coupled | bridging: displacement | bridging: rotation "
             "| DE zone: displacement | DE zone: rotation |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['variant']}, r = {r['relaxation']:g} | "
                     f"{'yes' if r['rotations_coupled'] else 'no'} | "
                     f"{100 * r['bridging_displacement']:.2f} % | {100 * r['bridging_rotation']:.1f} % | "
                     f"{100 * r['de_zone_displacement']:.2f} % | {100 * r['de_zone_rotation']:.1f} % |")
    return "\n".join(lines) + "\n"


def _plot(path, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from common.files import save_figure
    import numpy as np
    fig, axes = plt.subplots(1, len(runs), figsize=(4 * len(runs), 3.6), sharey=True)
    for ax, (spec, r) in zip(np.atleast_1d(axes), runs):
        x = r["positions"][:, 0]
        exact = r["rotation_exact"][0]
        for name, colour in (("de_zone", "tab:gray"), ("bridging", "tab:blue")):
            m = r["sets"][name]
            ax.plot(x[m] * 1e3, r["rotation"][m, 0] / exact, ".", ms=3, color=colour,
                    label=name.replace("_", " "))
        ax.axhline(1.0, color="k", lw=1, label="exact")
        ax.set(title=f"{spec.variant} r={spec.relaxation:g}, rotations "
                     f"{'coupled' if spec.rotations else 'free'}", xlabel="x (mm)")
        ax.legend(fontsize=7)
    np.atleast_1d(axes)[0].set_ylabel("sphere rotation ω_x / exact")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
