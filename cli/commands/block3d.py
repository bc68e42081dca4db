"""`block3d`: the paper's 3D check, a coupled elastic block sheared slowly into a known field."""
from cli.commands._options import add_out, add_weighting, ranged

NAME = "block3d"
HELP = ("3D check (paper §2): coupled YADE/FE block under a slow simple shear; error of the "
        "bridging spheres' displacements and rotations with and without rotation coupling")

STEPS = ranged(1, 10**7, int, low_open=False)


def configure(p):
    p.add_argument("--gamma", type=ranged(0, 0.01), default=1e-4,
                   help="shear strain amplitude (default 1e-4)")
    p.add_argument("--ramp-steps", type=STEPS, default=600,
                   help="steps of the smooth ramp (default 600)")
    p.add_argument("--hold-steps", type=STEPS, default=400,
                   help="steps held at full load, over which the answer is averaged (default 400)")
    p.add_argument("--layers", type=ranged(1, 10, int, False), default=2,
                   help="bridging layers (default 2)")
    p.add_argument("--radius", type=ranged(0, 0.01), default=0.003,
                   help="sphere radius in m (default 0.003: the block is 20 radii wide)")
    p.add_argument("--packing", choices=("random", "cubic"), default="random",
                   help="spheres: a random dense packing (default) or a simple cubic lattice, "
                        "for which the affine field is exact")
    p.add_argument("--diagonal-relaxation", type=ranged(0, 1e6), default=None,
                   help="r of the diagonal variant's runs (default 35)")
    p.add_argument("--variants", nargs="+", choices=("full", "diagonal"),
                   default=["full", "diagonal"], help="coupled variants to run (default both)")
    p.add_argument("--uncoupled", action="store_true",
                   help="also run the spheres alone (walls prescribed, no coupling, the FE not "
                        "stepped): the packing's own error")
    add_weighting(p, "consistent")
    add_out(p, "results folder")


def run(args):
    from dataclasses import replace
    from cases.block3d import BlockSpec, ShearCheck, run_shear_check
    from common.files import write_json, write_text
    from orchestrator.run.folder import prepare_out
    check = ShearCheck(gamma=args.gamma, ramp_steps=args.ramp_steps, hold_steps=args.hold_steps)
    if args.diagonal_relaxation is not None and "diagonal" not in args.variants:
        raise ValueError("--diagonal-relaxation acts only on the diagonal variant's runs: give "
                         "--variants diagonal (or both)")
    r = 35.0 if args.diagonal_relaxation is None else args.diagonal_relaxation
    cases = [(v, r) for v, r in (("full", 1.0), ("diagonal", r))
             if v in args.variants]
    options = dict(layers=args.layers, weighting=args.weighting, radius=args.radius,
                   packing=args.packing)
    runs_to_do = [(BlockSpec(variant=v, relaxation=r, rotations=rot, **options), check)
                  for v, r in cases for rot in (True, False)]
    if args.uncoupled:
        runs_to_do.append((BlockSpec(rotations=False, **options), replace(check, coupled=False)))
    out = prepare_out(args.out, args.force)
    rows, runs, guarded = [], [], None
    for spec, chk in runs_to_do:
        result = run_shear_check(spec, chk)
        # the spheres whose rotation rows the diagonal solver guards, measured in the run with
        # rotations coupled, and the same spheres in the run without
        if "bridging_guarded" in result["sets"]:
            guarded = result["sets"]["bridging_guarded"]
        elif guarded is not None and spec.variant == "diagonal" and chk.coupled:
            _add_split(result, guarded)
        runs.append((spec, result, chk.coupled))
        e = result["errors"]
        rows.append({"variant": spec.variant if chk.coupled else "none",
                     "relaxation": spec.relaxation, "coupled": chk.coupled,
                     "rotations_coupled": spec.rotations and chk.coupled, **{
                         f"{where}_{what}": e[where][what] for where in e
                         for what in ("displacement", "rotation")},
                     "bridging_spheres": e["bridging"]["spheres"],
                     "de_zone_spheres": e["de_zone"]["spheres"], "dt": result["dt"],
                     "guarded_rotation_rows": result["guarded_rotation_rows"],
                     "guarded_spheres": e.get("bridging_guarded", {}).get("spheres", 0),
                     "rotation_rows": result["rotation_rows"]})
        print(f"{_label(rows[-1])}, rotations {'on ' if spec.rotations else 'off'}"
              f" ({result['guarded_rotation_rows']} of {result['rotation_rows']} rotation rows "
              f"guarded): "
              f"bridging spheres: displacement {100 * rows[-1]['bridging_displacement']:.2f} %, "
              f"rotation {100 * rows[-1]['bridging_rotation']:.1f} %; DE zone: "
              f"{100 * rows[-1]['de_zone_displacement']:.2f} %, "
              f"{100 * rows[-1]['de_zone_rotation']:.1f} %")
    write_json(out / "check.json", {"check": vars(check), "layers": args.layers,
                                    "radius": args.radius, "packing": args.packing,
                                    "weighting": args.weighting, "rows": rows})
    write_text(out / "table.md", _table(rows))
    _plot(out / "block3d.png", runs)
    print(f"results in {out}")
    return 0


def _table(rows):
    lines = ["| coupling | rotations coupled | guarded rotation rows | bridging: displacement "
             "| bridging: rotation | rotation of guarded / other bridging spheres "
             "| DE zone: displacement | DE zone: rotation |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        guarded = (f"{r['guarded_rotation_rows']} of {r['rotation_rows']}" if r["rotation_rows"]
                   else "-")
        lines.append(f"| {_label(r)} | {'yes' if r['rotations_coupled'] else 'no'} | {guarded} | "
                     f"{100 * r['bridging_displacement']:.2f} % | {100 * r['bridging_rotation']:.1f} % | "
                     f"{_split(r)} | "
                     f"{100 * r['de_zone_displacement']:.2f} % | {100 * r['de_zone_rotation']:.1f} % |")
    return "\n".join(lines) + "\n"


def _add_split(result, guarded):
    from cases.block3d import relative_rms
    import numpy as np
    exact = result["rotation_exact"]
    for name, mask in (("bridging_guarded", guarded),
                       ("bridging_unguarded", result["sets"]["bridging"] & ~guarded)):
        result["errors"][name] = {
            "spheres": int(mask.sum()), "displacement": relative_rms(
                result["displacement"][mask],
                result["displacement_exact"][mask]),
            "rotation": relative_rms(result["rotation"][mask],
                                      np.broadcast_to(exact, (mask.sum(), 3)))}


def _split(row):
    if "bridging_guarded_rotation" not in row:
        return "-"
    return (f"{100 * row['bridging_guarded_rotation']:.1f} % ({row['guarded_spheres']}) / "
            f"{100 * row['bridging_unguarded_rotation']:.1f} %")


def _label(row):
    if not row["coupled"]:
        return "none (spheres alone)"
    return f"{row['variant']}, r = {row['relaxation']:g}"


def _plot(path, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from common.files import save_figure
    fig, axes = plt.subplots(1, len(runs), figsize=(4 * len(runs), 3.6), sharey=True)
    for ax, (spec, r, coupled) in zip(np.atleast_1d(axes), runs):
        x = r["positions"][:, 0]
        exact = r["rotation_exact"][0]
        for name, colour in (("de_zone", "tab:gray"), ("bridging", "tab:blue")):
            m = r["sets"][name]
            ax.plot(x[m] * 1e3, r["rotation"][m, 0] / exact, ".", ms=3, color=colour,
                    label=name.replace("_", " "))
        ax.axhline(1.0, color="k", lw=1, label="exact")
        title = (f"{spec.variant} r={spec.relaxation:g}, rotations "
                 f"{'coupled' if spec.rotations else 'free'}" if coupled else "spheres alone")
        ax.set(title=title, xlabel="x (mm)")
        ax.legend(fontsize=7)
    np.atleast_1d(axes)[0].set_ylabel("sphere rotation ω_x / exact")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
