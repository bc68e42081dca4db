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
    full, coupled = Path(args.full_dir), Path(args.coupled_dir)
    for d, model in ((full, "full"), (coupled, "coupled")):
        check_slab_run(d, model)
    out = prepare_out(args.out, args.force, inputs=(full, coupled))
    r = compare(full, coupled, out)
    for name, s in r["sensors"].items():
        print(f"{name:14s} peak ratio {_figure(s['peak_ratio'], '.3f')}  nRMS "
              f"{_figure(s['nrms'], '.3f')}  peak at {s['peak_time_full_s'] * 1e3:.2f} ms (full), "
              f"{s['peak_time_coupled_s'] * 1e3:.2f} ms (coupled)")
    print(f"damaged volume ratio {r['damage']['damaged_volume_ratio']}, damage-map correlation "
          f"{r['damage']['damage_map_correlation_de_zone']}, speed-up per step "
          f"{r['speedup_per_step']:.2f} (sphere ratio {r['sphere_count_ratio']:.2f})")
    print(f"goals: {r['goals']}; results in {out}")
    return 0


def check_slab_run(folder, model):
    """Refuse, before anything is written, a folder that is not a finished slab run of `model`."""
    import json
    summary = folder / "summary.json"
    if not summary.is_file():
        raise FileNotFoundError(f"{folder} is not a finished slab run (no summary.json)")
    try:
        s = json.loads(summary.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{summary}: unreadable ({e})") from None
    if "model" not in s or "spec" not in s:
        raise ValueError(f"{folder} holds a run of case {s.get('case')!r} ({s.get('kind')}), "
                         f"not a slab run: compare takes a full and a coupled slab run")
    if s["model"] != model:
        raise ValueError(f"{folder} holds a {s['model']!r} slab run, expected {model!r} "
                         f"(compare FULL_DIR COUPLED_DIR)")
    for name in ("sensors.csv", "damage.npz"):
        if not (folder / name).is_file():
            raise FileNotFoundError(f"{folder} has no {name}: not a finished slab run")


def _figure(value, spec):
    """A ratio, or n/a when it has no meaning (a sensor of the full run that did not move)."""
    return "n/a" if value is None else format(value, spec)
