"""`compare`: a coupled slab run against a full-YADE run of the same slab."""
from orchestrator.commands._options import add_out

NAME = "compare"
HELP = "compare FULL_DIR COUPLED_DIR: sensor histories, damage maps, speed-up"


def configure(p):
    p.add_argument("full_dir")
    p.add_argument("coupled_dir")
    add_out(p, "folder for comparison.json and plots")


def run(args):
    from pathlib import Path
    from cases.slab import compare
    from orchestrator.run.folder import prepare_out
    for d in (args.full_dir, args.coupled_dir):
        if not (Path(d) / "summary.json").is_file():
            raise FileNotFoundError(f"{d} is not a slab results folder (no summary.json)")
    out = prepare_out(args.out, args.force)
    r = compare(Path(args.full_dir), Path(args.coupled_dir), out)
    for name, s in r["sensors"].items():
        print(f"{name:14s} peak ratio {s['peak_ratio']:.3f}  nRMS {s['nrms']:.3f}  peak at "
              f"{s['peak_time_full_s'] * 1e3:.2f} ms (full), {s['peak_time_coupled_s'] * 1e3:.2f} ms"
              " (coupled)")
    print(f"damaged volume ratio {r['damage']['damaged_volume_ratio']}, damage-map correlation "
          f"{r['damage']['damage_map_correlation_de_zone']}, speed-up per step "
          f"{r['speedup_per_step']:.2f} (sphere ratio {r['sphere_count_ratio']:.2f})")
    print(f"goals: {r['goals']}; results in {out}")
    return 0
