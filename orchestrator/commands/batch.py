"""`batch`: many case files, or one case with a parameter table, N runs at a time
(the Docker image's entrypoint)."""
from orchestrator.commands._options import add_out, count

NAME = "batch"
HELP = "batch CASE.toml [CASE.toml ...] [--table PARAMS.csv] -j N --out DIR: runs and a summary CSV"


def configure(p):
    p.add_argument("cases", nargs="+", help="case files (one, with --table)")
    p.add_argument("--table", help="parameter table: CSV of dotted case keys, one run per row")
    p.add_argument("-j", "--jobs", type=count, default=1, help="runs at a time (default 1)")
    add_out(p, "folder for the runs and batch_summary.csv")


def run(args):
    from orchestrator.batch import plan, run_batch
    from orchestrator.run.folder import prepare_out
    jobs = plan(args.cases, args.table)      # every input checked before the folder is made
    inputs = [*args.cases, *([args.table] if args.table else [])]
    out = prepare_out(args.out, args.force, inputs)
    rows = run_batch(jobs, out, args.jobs)
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"batch: {len(rows) - len(failed)} of {len(rows)} runs ok; summary in "
          f"{out / 'batch_summary.csv'}")
    for r in failed:
        print(f"  failed {r['name']}: {r['error']}")
    return 1 if failed else 0
