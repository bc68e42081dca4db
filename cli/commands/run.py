"""`run`: a coupled case described in a TOML case file (docs/case-files.md)."""
from cli.commands._options import add_out, add_threads

NAME = "run"
HELP = "run CASE.toml [--set key=value ...] [--out DIR]: a case described in a case file"


def configure(p):
    p.add_argument("case", nargs="?", help="case file (TOML; see docs/case-files.md)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a case-file key (TOML value), e.g. --set coupling.relaxation=20")
    add_out(p, "results folder (default: results/<case name>)", required=False)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_threads(p)
    p.add_argument("--resume", metavar="DIR",
                   help="carry on a stopped run from its checkpoint (its folder's case.toml)")


def run(args):
    from pathlib import Path
    from cases.kinds import case_inputs, load_case as load, run_case
    from orchestrator.run.folder import check_out, resume_folder, input_files
    if args.resume:
        if args.case or args.set or args.out or args.force:
            raise ValueError("--resume DIR takes the case, its settings and the folder from DIR: "
                             "give no case file, --set, --out or --force with it")
        from orchestrator.run.restart import check_inputs, resume_meta
        out = Path(args.resume)
        from cases.slab.grow import fallback_spec
        if fallback_spec(out) is not None:
            raise ValueError(f"{out}: its zone reached its limit and the full model it fell "
                             f"back to was stopped: carry it on with `slab --resume {out}`")
        meta = resume_meta(out)               # a clear error if there is no checkpoint
        info = meta["info"]
        if args.threads is None:        # the run's own threads: a 1-thread run stays bit-identical
            args.threads = meta.get("yade_threads")
        if not (out / "case.toml").is_file() and "spec" in info:
            raise ValueError(f"{out} holds a checkpoint of the slab command (no case.toml): "
                             f"resume it with `slab --resume`")
        case = load(out / "case.toml")
        check_inputs(out, case_inputs(case))  # the same case, before anything is built
        resume_folder(out)
    else:
        if not args.case:
            raise ValueError("give a case file, or --resume DIR")
        case = load(args.case, args.set)      # every key checked before anything runs
        out = Path(args.out or Path("results") / case["case"]["name"])
        check_out(out, args.force, input_files(case))   # refuse before building, not after
    from cli.mpi import case_ranks
    ranks = case_ranks(case)
    if ranks:
        from cli.mpi import on_ranks
        code = on_ranks(ranks, args)
        if code is not None:
            return code
    s = run_case(case, out, force=args.force, quiet=args.quiet, threads=args.threads,
                 resume=bool(args.resume))
    if case.kind == "wave1d":        # the wave1d command printed its own result line
        return 0
    print(f"{case['case']['name']} ({case.kind}): {s['n_spheres']} spheres, {s['n_fe_nodes']} "
          f"FE nodes, {s['n_bridging_spheres']} bridging spheres, {s['steps']} steps of "
          f"{s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; results in {out}")
    return 0
