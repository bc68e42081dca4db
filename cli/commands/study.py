"""`study`: where coupling pays. The map of the coupled slab (cases.slab.study.plan says which
runs): each impact's full ensemble and coupled zones on the same seeds, judged by the
yardstick, at medium scale and, in the full sweep, at paper scale with the zone the medium map
chooses; the table, plots and docs page written from the run folders. Runs already finished
with the same description are reused, so the study resumes where it stopped."""
import argparse

from cli.commands._options import add_threads, list_of, ranged
from orchestrator.casefile import MAX_STEPS

NAME = "study"
HELP = ("where coupling pays: the coupled slab judged by the yardstick against the full "
        "ensemble of each impact, and its speed-up, 10-40 m/s at medium scale, and at paper "
        "scale (make study)")
OUT = "results/where-coupling-pays"
PAGE = "page.md"      # the page written whole from the table, in the study's folder


def configure(p):
    p.add_argument("--sweep", choices=("default", "full"), default="default",
                   help="default: medium scale, 10 and 40 m/s, the 0.5 m box and the grown "
                        "zone on seeds 1-4 (--dry-run gives its projected hours); full: 10, "
                        "20 and 40 m/s, the 1.0 m box, the reinforced slab and the paper "
                        "scale on seeds 1-3")
    p.add_argument("--out", default=OUT, help=f"the study's folder (default {OUT})")
    p.add_argument("--reuse-ensembles", nargs="+", default=[], metavar="DIR",
                   help="folders of finished slab runs to reuse when they have the same "
                        "description, e.g. results/slab-medium of make validate")
    p.add_argument("--only", choices=("medium", "paper"), default=None,
                   help="only the medium map, or only the paper scale")
    p.add_argument("--velocities", type=list_of(float, "numbers"), default=None,
                   metavar="V,V,...",
                   help="impact velocities (m/s) among 10, 20, 40 (default: 10,40; full "
                        "sweep: 10,20,40)")
    p.add_argument("--paper-seeds", type=list_of(int, "integers"), default=None,
                   metavar="S,S,...",
                   help="the paper scale's packing seeds (default: none; full sweep: "
                        "1,2,3); the yardstick needs two or more")
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
    if args.scale not in ("small", "medium"):
        raise ValueError(f"study: --scale must be small or medium, got {args.scale!r}")
    bench = sp.load_bench()
    index = sp.ensemble_index(args.reuse_ensembles) if args.reuse_ensembles else {}
    options = dict(sweep=args.sweep, velocities=args.velocities, scale=args.scale,
                   steps=args.steps, seeds=args.seeds, paper_seeds=args.paper_seeds)
    out = Path(args.out)
    medium = sp.plan(only="medium", **options)      # --only says what runs, not what is shown
    if not sp.plan(only=args.only, **options):      # every option checked before a run
        raise ValueError("study: --only paper runs nothing without paper seeds: give "
                         "--paper-seeds or --sweep full")
    if args.dry_run:
        return _dry_run(medium, options, args, out, index, bench)
    from cases.slab.study import report, table as st
    from cases.slab.study.runs import execute
    from yade_side import import_yade
    _prepare(out)
    import_yade(args.threads)
    outcomes = execute(medium, out, index, args.quiet, dry=args.only == "paper")
    # the zone the paper scale takes, by the one-window timing: the runs' own wall times
    # depend on what else the machine ran meanwhile
    def timing(runs):
        return None if args.no_timing else _timing(runs, outcomes, out)
    choice = st.choose(st.build(medium, out, index, timing(medium)))
    paper = sp.plan(only="paper", paper_choice=choice, **options)
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
    for impact in table["impacts"]:
        for row in impact["configs"]:
            print(f"{report.impact_title(impact)}, {row['config']}: "
                  f"{report.outcome(row['goal'])}: {row['goal']['why']}")
    if not report.qualifying(table):
        print("no zone is shown equivalent and cheap enough (table.md has the figures)")
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


def _projected(runs, bench):
    from cases.slab.study import plan as sp
    return sum(sp.run_cost(r, bench) for r in runs) + sp.timing_cost(runs, bench)


def _plots(table, out):
    """One PNG per impact in `out`, beside the page; {group: its name}."""
    from cases.slab.study.report import plot_impact
    images = {}
    for impact in table["impacts"]:
        images[impact["group"]] = f"{impact['group']}.png"
        plot_impact(impact, out / images[impact["group"]])
    return images


def _dry_run(medium, options, args, out, index, bench):
    """The plan, one line per run: folder, steps, projected cost, and what is done (the
    paper scale's zone as the finished medium runs and the recorded timing.json choose it)."""
    import json
    from cases.slab.study import plan as sp, table as st
    choice = {}
    if all(sp.where(r, out, index)[1] is not None for r in medium):
        path = out / "timing.json"
        timing = None if args.no_timing or not path.is_file() else json.loads(path.read_text())
        choice = st.choose(st.build(medium, out, index, timing))
    paper = sp.plan(only="paper", paper_choice=choice, **options)
    runs = {"medium": medium, "paper": paper, None: medium + paper}[args.only]
    left = 0.0
    print(f"{'run':46s} {'steps':>7s} {'projected':>10s}  status")
    for r in runs:
        cost = sp.run_cost(r, bench)
        folder, summary = sp.where(r, out, index)
        status = ("done" if summary is not None and folder == out / r.folder else
                  f"reused: {folder}" if summary is not None else "to run")
        left += cost if summary is None else 0.0
        print(f"{r.folder:46s} {r.spec().steps or 'default':>7} {cost:9.0f}s  {status}")
    timing = sp.timing_cost(runs, bench)
    print(f"{'one-window timing of each model':46s} {'':7s} {timing:9.0f}s")
    every = sum(sp.run_cost(r, bench) for r in runs) + timing
    print(f"projected on one quiet core (bench/results.json; a grown zone as its start box): "
          f"{every / 3600:.2f} h for the plan, {(left + timing) / 3600:.2f} h still to run")
    return 0
