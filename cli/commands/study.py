"""`study`: where coupling pays. The accuracy-cost map of the coupled slab at medium
scale (cases.slab.study.plan says which runs), the paper-scale pair of the configuration it
says pays, and the table, plots and docs page written from the run folders. Runs already
finished with the same description are reused, so the study resumes where it stopped."""
import argparse

from cli.commands._options import add_threads, list_of, ranged
from orchestrator.casefile import MAX_STEPS

NAME = "study"
HELP = ("where coupling pays: the coupled slab's error against the full scatter and its "
        "speed-up, 10-40 m/s at medium scale, and the paper-scale pair (make study)")
OUT = "results/where-coupling-pays"
PAGE = "page.md"      # the page written whole from the table, in the study's folder


def configure(p):
    p.add_argument("--sweep", choices=("default", "full"), default="default",
                   help="default: the plan that fits about 3 h of one core; full: every "
                        "configuration at every velocity and seed, and the reinforced slab "
                        "(about 8.6 h)")
    p.add_argument("--out", default=OUT, help=f"the study's folder (default {OUT})")
    p.add_argument("--reuse-ensembles", nargs="+", default=[], metavar="DIR",
                   help="folders of finished slab runs to reuse when they have the same "
                        "description, e.g. results/slab-medium of make validate")
    p.add_argument("--only", choices=("medium", "paper"), default=None,
                   help="only the medium map, or only the paper pair")
    p.add_argument("--velocities", type=list_of(float, "numbers"), default=None,
                   metavar="V,V,...",
                   help="impact velocities (m/s) among 10, 20, 40 (default: 10,40; full "
                        "sweep: 10,20,40)")
    p.add_argument("--paper-seeds", type=list_of(int, "integers"), default=None,
                   metavar="S,S,...",
                   help="the paper pair's packing seeds (default: 1; full sweep: 1,2); a "
                        "verdict against the paper scale's full scatter needs two")
    p.add_argument("--dry-run", action="store_true",
                   help="print the plan, one line per run with its projected cost, and stop")
    p.add_argument("--no-timing", action="store_true",
                   help="no one-window timing of the models: speed-ups from the runs' own "
                        "wall times")
    add_threads(p, default=1)     # one run at a time, bit-identical: the budget is one core
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    # the machinery at a small scale and a few steps, for its tests
    p.add_argument("--scale", default="medium", help=argparse.SUPPRESS)
    p.add_argument("--steps", type=ranged(1, MAX_STEPS, int, False), default=None,
                   help=argparse.SUPPRESS)
    p.add_argument("--seeds", type=list_of(int, "integers"), default=None, help=argparse.SUPPRESS)


def run(args):
    from pathlib import Path
    from cases.slab.study import plan as sp
    if args.scale not in sp.LARGER_ZONE:
        raise ValueError(f"study: --scale must be one of {', '.join(sp.LARGER_ZONE)}, got "
                         f"{args.scale!r}")
    bench = sp.load_bench()
    index = sp.ensemble_index(args.reuse_ensembles) if args.reuse_ensembles else {}
    options = dict(sweep=args.sweep, velocities=args.velocities, scale=args.scale,
                   steps=args.steps, seeds=tuple(args.seeds or sp.SEEDS), bench=bench,
                   paper_seeds=None if args.paper_seeds is None else tuple(args.paper_seeds))
    out = Path(args.out)
    medium = sp.plan(only="medium", **options)      # --only says what runs, not what is shown
    if args.dry_run:
        return _dry_run(medium, options, args, out, index, bench)
    from cases.slab.study import report, table as st
    from cases.slab.study.runs import execute
    from yade_side import import_yade
    _prepare(out)
    import_yade(args.threads)
    outcomes = execute(medium, out, index, args.quiet, dry=args.only == "paper")
    # which zones qualify, to confirm and to take to paper scale, by the one-window timing:
    # the runs' own wall times depend on what else the machine ran meanwhile
    def timing(runs):
        return None if args.no_timing else _timing(runs, outcomes, out)
    medium, choice = _confirm_and_choose(
        medium, out, index, timing,
        lambda extra: outcomes.update(execute(extra, out, index, args.quiet,
                                              dry=args.only == "paper")))
    paper = sp.plan(only="paper", paper_config=choice, **options)
    outcomes.update(execute(paper, out, index, args.quiet, dry=args.only == "medium"))
    runs = medium + paper
    table = st.build(runs, out, index, timing(runs))
    table["table1"] = report.table1(table)
    projected = _projected(runs, bench)
    table["plan"] = {"sweep": args.sweep, "projected_s": projected, "budget_s": sp.BUDGET_S,
                     "runs": [{"folder": r.folder, "seed": r.seed, "steps": r.spec().steps,
                               "status": outcomes[r.folder].status} for r in runs]}
    images = _plots(table, out)
    command = ("python3 -m cli study"
               + ("" if args.sweep == "default" else f" --sweep {args.sweep}")
               + ("" if args.velocities is None else
                  " --velocities " + ",".join(f"{v:g}" for v in args.velocities))
               + ("" if args.paper_seeds is None else
                  " --paper-seeds " + ",".join(map(str, args.paper_seeds))))
    text = report.doc(table, runs, outcomes, projected, args.sweep, images, command)
    report.write(table, out, PAGE, text)
    for impact, row in report.qualifying(table):
        print(f"qualifies: {report.impact_title(impact)}, {row['config']}: {row['goal']['why']}")
    if not report.qualifying(table):
        print("no configuration qualifies at this resolution (table.md has the figures)")
    print(f"results in {out}; the page: {out / PAGE} and {out / 'report.html'}")
    return 0


def _prepare(out):
    """The study's folder: made, or an earlier one of the project's carried on."""
    from common.files import MARKER, mark
    from orchestrator.run.folder import check_out
    if not (out / MARKER).is_file():
        check_out(out)        # a new folder, or an empty one: nothing of an earlier study
        out.mkdir(parents=True, exist_ok=True)
        mark(out)


def _timing(runs, outcomes, out):
    import json
    from bench.study_timing import time_models
    path = out / "timing.json"
    previous = json.loads(path.read_text()) if path.is_file() else None
    return time_models(runs, outcomes, path, previous)


def _confirm_and_choose(medium, out, index, timing, run_extra):
    """The fixed zones that qualify on seed 1, confirmed on the other seeds (`run_extra` runs
    them), and the zone the map then chooses for paper scale; `timing(runs)`: the one-window
    timing of the runs (None: their own wall times). Returns (medium runs and confirmations,
    choice)."""
    from cases.slab.study import plan as sp, table as st
    extra = sp.confirmations(medium, st.qualifying_configs(
        st.build(medium, out, index, timing(medium)), medium))
    run_extra(extra)
    medium = medium + extra
    return medium, st.choose(st.build(medium, out, index, timing(medium)))


def _projected(runs, bench):
    from cases.slab.study import plan as sp
    return (sum(sp.run_cost(r, bench) for r in runs if r.when is None)
            + sp.timing_cost(runs, bench))


def _plots(table, out):
    """One PNG per impact in `out`, beside the page; {group: its name}."""
    from cases.slab.study.report import plot_impact
    images = {}
    for impact in table["impacts"]:
        if impact["scale"] != "paper":
            images[impact["group"]] = f"{impact['group']}.png"
            plot_impact(impact, out / images[impact["group"]])
    return images


def _dry_run(medium, options, args, out, index, bench):
    """The plan, one line per run: folder, steps, projected cost, and what is done (the
    confirmations and the paper zone as the recorded timing.json says)."""
    import json
    from cases.slab.study import plan as sp
    choice, confirming = None, "(seeds 2 and 3 of each fixed zone that qualifies on seed 1)"
    if all(sp.where(r, out, index)[1] is not None for r in medium if r.when is None):
        path = out / "timing.json"
        timing = None if args.no_timing or not path.is_file() else json.loads(path.read_text())
        medium, choice = _confirm_and_choose(medium, out, index, lambda runs: timing,
                                             lambda extra: None)
        confirming = None
    paper = sp.plan(only="paper", paper_config=choice, **options)
    runs = {"medium": medium, "paper": paper, None: medium + paper}[args.only]
    total = conditional = 0.0
    print(f"{'run':46s} {'steps':>6s} {'projected':>10s}  status")
    for r in runs:
        cost = sp.run_cost(r, bench)
        folder, summary = sp.where(r, out, index)
        status = ("done" if summary is not None and folder == out / r.folder else
                  f"reused: {folder}" if summary is not None else "to run")
        if r.when is not None:
            status += f" (only if {r.when} ends clean)"
            conditional += cost
        elif summary is None:
            total += cost
        if r.chosen:
            status += " (zone chosen by the medium map; shown: the paper scale's own)"
        print(f"{r.folder:46s} {r.spec().steps:6d} {cost:9.0f}s  {status}")
    if confirming and args.only != "paper":
        print(f"{'confirmations, once the map is made':46s} {'':6s} {'':>10s}  {confirming}")
    timing = sp.timing_cost(runs, bench)
    print(f"{'one-window timing of each model':46s} {'':6s} {timing:9.0f}s")
    every = sum(sp.run_cost(r, bench) for r in runs if r.when is None) + timing
    print(f"projected on one quiet core (bench/results.json): {every / 3600:.2f} h for the "
          f"plan, {(total + timing) / 3600:.2f} h still to run, +{conditional / 3600:.2f} h if "
          f"the automatic zones end clean; budget {sp.BUDGET_S / 3600:.1f} h")
    print(f"reinforced concrete: {sp.REINFORCED_ROWS}")
    return 0
