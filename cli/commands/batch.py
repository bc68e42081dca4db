"""`batch`: many case files, or one case with a parameter table, N runs at a time
(the Docker image's entrypoint), or a Slurm job array of them."""
from cli.commands._options import add_out, count, ranged

NAME = "batch"
HELP = ("batch CASE.toml [CASE.toml ...] [--table PARAMS] -j N --out DIR: runs and a summary "
        "CSV (--slurm: a Slurm job-array script instead)")


def configure(p):
    p.add_argument("cases", nargs="+", help="case files (one, with --table)")
    p.add_argument("--table", help="parameter table, one run per row: CSV of dotted case keys, "
                                   "or yade-batch's whitespace table")
    p.add_argument("-j", "--jobs", type=count, default=None, help="runs at a time (default 1)")
    p.add_argument("--slurm", action="store_true",
                   help="write DIR/batch.sbatch, a Slurm job array of one task per run "
                        "(submit it with sbatch), instead of running")
    p.add_argument("--task", type=ranged(0, 10**7, int, False), metavar="K",
                   help="run only run K of the batch in DIR written by --slurm (what each "
                        "array task runs)")
    add_out(p, "folder for the runs and batch_summary.csv")


def run(args):
    from cli.batch import plan, run_batch
    from orchestrator.run.folder import prepare_out
    if args.slurm and args.jobs is not None:
        raise ValueError("--slurm runs each run as its own array task: -j (runs at a time on "
                         "this machine) does not apply; give one or the other")
    if args.task is not None and (args.slurm or args.jobs is not None or args.force):
        raise ValueError("--task K runs one array task in the folder --slurm wrote: give no "
                         "--slurm, -j or --force with it")
    jobs = plan(args.cases, args.table)      # every input checked before the folder is made
    if args.task is not None:
        from cli.slurm import run_task
        row = run_task(jobs, args.out, args.task)
        print(f"batch task {args.task} ({row['name']}): {row['status']} {row['error']}".rstrip())
        return 0 if row["status"] == "ok" else 1
    inputs = [*args.cases, *([args.table] if args.table else [])]
    out = prepare_out(args.out, args.force, inputs)
    if args.slurm:
        from cli.slurm import write_script
        script = write_script(jobs, args.cases, args.table, out)
        print(f"batch: {len(jobs)} array tasks in {script}; submit with: sbatch {script}")
        return 0
    rows = run_batch(jobs, out, 1 if args.jobs is None else args.jobs)
    failed = [r for r in rows if r["status"] != "ok"]
    print(f"batch: {len(rows) - len(failed)} of {len(rows)} runs ok; summary in "
          f"{out / 'batch_summary.csv'}")
    for r in failed:
        print(f"  failed {r['name']}: {r['error']}")
    return 1 if failed else 0
