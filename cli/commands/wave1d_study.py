"""`wave1d-study`: the sweep of the paper's Figs. 4–7 and the check of the automatic r."""
from cli.commands._options import add_out, add_weighting, ranged
from orchestrator.coupling.assembly import MIN_SAFETY

NAME = "wave1d-study"
HELP = ("1D spurious-reflection sweep: 4 variants x n_b 1-6 x r 1-100 at ratio 5, and the "
        "automatic r at n_b = 3 for ratios 2-8; CSV, tables and figures")


def configure(p):
    add_out(p, "results folder")
    p.add_argument("--quick", action="store_true",
                   help="a coarse sweep (n_b 1, 3; 5 values of r; ratios 2, 5, 8) for a check")
    p.add_argument("--dt-safety", type=ranged(MIN_SAFETY, 1, low_open=False), default=0.8,
                   help="time step / the smaller critical step (default 0.8; the slab uses 0.3)")
    add_weighting(p, "nodal")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args):
    import numpy as np
    from cases import wave1d
    from orchestrator.run.folder import prepare_out
    options = dict(dt_safety=args.dt_safety, weighting=args.weighting)
    if args.quick:
        cases = wave1d.study_cases(layers=(1, 3), relaxations=tuple(np.logspace(0, 2, 5)),
                                   ratios=(2, 5, 8), **options)
    else:
        cases = wave1d.study_cases(**options)
    out = prepare_out(args.out, args.force)
    rows = wave1d.run_study(out, cases, quiet=args.quiet)
    print(wave1d.markdown_table(rows), end="")
    print(f"{len(rows)} runs; results in {out}")
    return 0
