"""`slab`: the paper's slab impact, full YADE or coupled YADE/FEniCSx. Every option but the
model, threads and folders is a field of cases.slab.SlabSpec, which holds the defaults."""
from cli.commands._options import (add_out, add_spec_options, add_threads, count,
                                            list_of, option, spec_from_args)

NAME = "slab"
HELP = "slab impact (paper §5): --model full|coupled --scale small|medium|paper"


def configure(p):
    from cases.slab import MODELS, SlabSpec
    p.add_argument("--model", choices=MODELS, default=None,
                   help="full: the whole slab in spheres; coupled: DE zone + FE "
                        "(required for a new run)")
    add_spec_options(p, SlabSpec)
    p.add_argument("--zone-from", metavar="DIR",
                   help="a fixed DE zone: the cells of the one the zone 'auto' or 'grow' run "
                        "in DIR ended with (its summary.json's zone_final)")
    p.add_argument("--seeds", type=_seed_list, metavar="N,N,...",
                   help="an ensemble: one run per packing seed, in DIR/seed-N (instead of --seed)")
    p.add_argument("--jobs", type=count, default=None,
                   help="ensemble members run at a time (default: one per core; with --mpi N, one "
                        "per N - 1 cores)")
    add_threads(p)
    p.add_argument("--resume", metavar="DIR",
                   help="carry on a stopped run from its checkpoint (other options are taken "
                        "from it); an ensemble's folder: its stopped members from theirs, "
                        "those not started from the start, --jobs at a time")
    add_out(p, "results folder", required=False)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args):
    from pathlib import Path
    from cases import slab
    from orchestrator.run import folder
    if args.resume and (Path(args.resume) / ENSEMBLE).is_file():
        return _resume_ensemble(args)
    if args.resume:
        spec, model = _from_checkpoint(args)
    elif args.out and args.model:
        if args.seeds and args.seed is not None:
            raise ValueError("give either --seed or --seeds, not both")
        zone_run = _zone_run(args.zone_from) if args.zone_from else None
        model = args.model
        args.zone = slab.SlabSpec.zone_for(model, args.zone, "--zone")
        spec = spec_from_args(slab.SlabSpec, args,
                              zone_cells=zone_run and zone_run["zone_final"]["cells"])
        if zone_run:
            _check_zone_fits(args.zone_from, zone_run, spec)
        slab.model.check_ranks(spec, model)     # before mpiexec starts
        _refuse_inert(args, spec, model)
        folder.check_out(args.out, args.force, _inputs(args))   # refuse before building, not after
    else:
        raise ValueError("give --model full|coupled and --out DIR for a new run, or --resume DIR")
    if args.seeds:
        from mpi4py import MPI
        if MPI.COMM_WORLD.size > 1:
            raise ValueError("--seeds runs its members as processes of their own: not under "
                             "mpirun")
        return _ensemble(model, args, spec)
    if args.jobs is not None:
        raise ValueError("--jobs is for an ensemble (--seeds)")
    if spec.mpi:
        from cli.mpi import on_ranks
        code = on_ranks(spec.mpi, args)       # before mpi4py starts: it needs mpiexec
        if code is not None:
            return code
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    if comm.size > 1 and not spec.mpi:
        # under mpirun the FE model is distributed; YADE and the coupling stay on rank 0
        if model != "coupled":
            raise ValueError(f"--model {model} has no FE part: run it without mpirun")
        if args.zone is None and not args.resume:
            from dataclasses import replace      # the FE is distributed once: a fixed zone
            spec = replace(spec, zone="box")
        if spec.zone != "box" or spec.dt_safety == "auto":
            raise ValueError(f"--zone {spec.zone} and --dt-safety auto build the model more "
                             f"than once: run them without mpirun")
        if comm.rank > 0:
            from cases.slab.zone import model_grid
            from fenicsx_side.distributed import serve
            grid = model_grid(spec)
            serve(slab.fe_model(spec, grid, slab.fe_weight(spec, grid)))
            return 0
    from yade_side import import_yade
    import_yade(args.threads)
    if args.resume:
        out, start = Path(args.resume), None
        folder.resume_folder(out)
    else:
        out, start = Path(args.out), lambda: folder.prepare_out(args.out, args.force, _inputs(args))
    s = slab.run(spec, model, out, quiet=args.quiet, resume=bool(args.resume), start=start)
    if s.get("zone_outcome") == "limit" and "n_spheres" not in s:
        return 1                # the one line saying why was printed
    _report(model, spec, s, out)
    return 0


def _refuse_inert(args, spec, model):
    """An option given that cannot act on this run: one line naming it and what it needs."""
    from cases.slab import SlabSpec
    from cli.commands._options import keyed_fields
    inert = spec.inert(model, [f.name for f in keyed_fields(SlabSpec)
                               if getattr(args, f.name) is not None])
    if inert:
        raise ValueError(f"{option(inert[0])} acts only on {inert[1]}; this run is --model "
                         f"{model}, zone {spec.zone!r}, fe.material {spec.fe_material!r}")
    if args.zone_from and model != "coupled":
        raise ValueError("--zone-from acts only on the coupled model (the DE zone it fixes)")


def _inputs(args):
    """The folders a new run reads, which --force must never replace."""
    return [args.zone_from] if args.zone_from else []


def _zone_run(folder):
    """The summary of the automatic or growing zone run in `folder`, which ended clean."""
    import json
    from pathlib import Path
    path = Path(folder) / "summary.json"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"--zone-from {folder}: cannot read its summary.json ({e})") from None
    if summary.get("zone_outcome") != "clean" or "zone_final" not in summary:
        raise ValueError(f"--zone-from {folder}: not a zone 'auto' or 'grow' run that ended "
                         f"clean (zone_outcome {summary.get('zone_outcome')!r})")
    return summary


def _check_zone_fits(folder, summary, spec):
    """The zone's cells of the run `folder` (its summary) are on this run's FE grid: the same
    scale, sphere size and FE ratios, the same cells. Another seed or impact is noted."""
    from cases.slab.zone import slab_grid
    theirs = summary.get("spec", {})
    for key in ("scale", "radius", "fe_ratio", "fe_ratio_thickness"):
        if key in theirs and theirs[key] != getattr(spec, key):
            raise ValueError(f"--zone-from {folder}: its run has {key} {theirs[key]!r}, this one "
                             f"{getattr(spec, key)!r}: its zone's cells lie on another FE grid")
    recorded = summary["zone_final"].get("grid", {}).get("n")
    grid = [int(n) for n in slab_grid(spec).n]
    if recorded is not None and recorded != grid:
        raise ValueError(f"--zone-from {folder}: its zone's FE grid has {recorded} cells, this "
                         f"run's {grid}")
    for key in ("seed", "impactor_speed"):
        if key in theirs and theirs[key] != getattr(spec, key):
            print(f"note: --zone-from {folder}: the zone was grown with {key} "
                  f"{theirs[key]!r}, this run has {getattr(spec, key)!r}")


def _from_checkpoint(args):
    """(spec, model) of the run to resume in args.resume; its threads unless --threads is
    given (a 1-thread run stays bit-identical)."""
    from cases.slab import SlabSpec
    from orchestrator.run.restart import resume_meta
    _refuse_with_resume(args, "the slab and its folder from DIR's checkpoint", "--jobs")
    from pathlib import Path
    from cases.slab.grow import fallback_spec
    grown = fallback_spec(args.resume)     # a grown run at its limit, its fallback stopped
    meta = resume_meta(Path(args.resume) / "full" if grown else args.resume)
    info = meta["info"]
    if args.threads is None:
        args.threads = meta.get("yade_threads")
    if grown is not None:
        return grown, "coupled"
    if "spec" not in info or "model" not in info:
        raise ValueError(f"{args.resume} holds a checkpoint of case {info.get('case')!r}, "
                         f"not of a slab run: resume it with `run --resume`")
    return SlabSpec(**info["spec"]), info["model"]


# the ensemble's record in its folder: each member's command line, for `--resume DIR`
ENSEMBLE = "ensemble.json"


def _ensemble(model, args, spec):
    """One member per seed, DIR/seed-N, each a `slab --seed N` process of its own, `--jobs` at
    a time (default: one per core, or per spec.mpi - 1 cores: each member's workers). Members
    run on one YADE thread unless --threads is given, so each is bit-identical to the same
    seed run alone with --threads 1. DIR/ensemble.json keeps each member's options (its
    folder apart: the ensemble's folder may move)."""
    from common.files import write_json
    from orchestrator.run.folder import prepare_out
    from yade_side import cores
    jobs = args.jobs or max(1, min(len(args.seeds), cores() // max(1, spec.mpi - 1)))
    if spec.mpi:
        from cli.mpi import check_machine
        check_machine(spec.mpi, min(jobs, len(args.seeds)))
    top = prepare_out(args.out, args.force, _inputs(args))
    argvs = {seed: ["--model", model, *_spec_argv(args, seed), "--threads",
                    str(args.threads or 1)] for seed in args.seeds}
    write_json(top / ENSEMBLE, {"members": {str(s): argv for s, argv in argvs.items()},
                                "mpi": spec.mpi})
    return _run_members(top, {s: argv + ["--out", str(top / f"seed-{s}")]
                              for s, argv in argvs.items()}, jobs, args.quiet)


def _resume_ensemble(args):
    """`slab --resume DIR` of an ensemble's folder: each member with results is left, a
    stopped one carries on from its checkpoint, one not started (or stopped before its first
    checkpoint) runs from the start, `--jobs` at a time."""
    import json
    from pathlib import Path
    from yade_side import cores
    _refuse_with_resume(args, f"the ensemble's members from DIR/{ENSEMBLE}")
    top = Path(args.resume)
    try:
        record = json.loads((top / ENSEMBLE).read_text())
        argvs = {int(s): list(argv) for s, argv in record["members"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
        raise ValueError(f"{top / ENSEMBLE}: unreadable ({e!r})") from None
    members, done = {}, []
    for seed, argv in sorted(argvs.items()):
        folder = top / f"seed-{seed}"
        if (folder / "summary.json").is_file():
            done.append(seed)
        elif _resumable(folder):
            members[seed] = ["--resume", str(folder)] + (
                ["--threads", str(args.threads)] if args.threads else [])
        else:
            # nothing of it to keep: from the start
            members[seed] = argv + ["--out", str(folder), "--force"]
    if not members:
        print(f"ensemble {top}: every member has its results")
        return 0
    print(f"ensemble {top}: " + "; ".join(
        f"seed {s} {'carries on' if m[0] == '--resume' else 'runs'}"
        for s, m in members.items()) + (f"; seeds {', '.join(map(str, done))} done" if done
                                         else ""))
    jobs = args.jobs or max(1, min(len(members), cores() // max(1, record.get("mpi", 0) - 1)))
    return _run_members(top, members, jobs, args.quiet)


def _refuse_with_resume(args, what, *more):
    """One line for an option given with --resume DIR, which takes `what` from DIR."""
    from dataclasses import fields
    from cases.slab import SlabSpec
    given = [option(f.name) for f in fields(SlabSpec) if getattr(args, f.name, None) is not None]
    given += [o for o in ("--model", "--out", "--force", "--seeds", *more)
              if getattr(args, o[2:].replace("-", "_"))]
    if given:
        raise ValueError(f"--resume DIR takes {what}: give no {', '.join(given)} with it")


def _resumable(folder):
    """A member folder that a `slab --resume` carries on: its checkpoint, or the checkpoint of
    the full model a grown zone at its limit fell back to."""
    return any((f / "checkpoint" / "meta.json").is_file() for f in (folder, folder / "full"))


def _run_members(top, members, jobs, quiet):
    """Run the members ({seed: `slab` options}) of the ensemble in `top`, `jobs` at a time;
    SIGTERM or SIGINT stops the running ones (each checkpoints) and starts no more."""
    import signal
    import subprocess
    import sys
    import threading
    from concurrent.futures import ThreadPoolExecutor
    from cli.mpi import environment_without_mpi
    from orchestrator.run.restart import Stopped
    quiet = quiet or jobs > 1          # one progress bar per terminal
    running, lock, stopped = set(), threading.Lock(), []

    def member(seed):
        cmd = ([sys.executable, "-m", "cli", "slab", *members[seed]]
               + (["--quiet"] if quiet else []))
        with lock:
            if stopped:                     # asked to stop: start no more members
                return None
            proc = subprocess.Popen(cmd, env=environment_without_mpi())
            running.add(proc)
        code = proc.wait()
        with lock:
            running.discard(proc)
        return code

    def stop(signum, _frame):
        """Stop the members as this process was asked to (each checkpoints: --resume)."""
        with lock:
            stopped.append(signum)
            for proc in running:
                proc.send_signal(signum)

    previous = {s: signal.signal(s, stop) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            codes = dict(zip(members, pool.map(member, members)))
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    if stopped:
        raise Stopped(f"ensemble {top}: stopped, and its running members with it; `slab "
                      f"--resume {top}` carries them on and runs those not started",
                      stopped[0])
    why = {s: _why_no_result(top / f"seed-{s}", c) for s, c in codes.items() if c}
    failed = [f"seed {s} ({text})" for s, (text, _) in why.items()]
    if any(not outcome for _, outcome in why.values()):
        raise ValueError(f"ensemble {top}: {len(failed)} of {len(codes)} members gave no "
                         f"result: {', '.join(failed)}; each member's folder says why")
    if failed:      # an outcome, as for one run (exit 1): the zone says coupling cannot pay
        print(f"ensemble {top}: {len(failed)} of {len(codes)} members end with no result: "
              f"{', '.join(failed)}")
        return 1
    return 0


def _why_no_result(folder, code):
    """(why, outcome) of a member that exited with `code`: what its automatic zone reached
    (an outcome, not a fault: outcome True), else its exit code."""
    import json
    try:
        s = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return f"exit {code}", False
    if code != 1 or s.get("zone_outcome") != "limit":
        return f"exit {code}", False
    reached = {"cells": "the zone's limit", "cost": "the budget, zone.cost"}.get(
        s.get("zone_limit_reached"), "its limit")
    if "zone_conversions" in s:
        return (f"coupling cannot pay: its growing zone reached {reached} after "
                f"{len(s['zone_conversions'])} conversions"), True
    return (f"coupling cannot pay: its zone search reached {reached} after "
            f"{len(s.get('zone_attempts', []))} attempts"), True


def _spec_argv(args, seed):
    """The slab options of this command line, with packing `seed` instead of --seeds."""
    from cases.slab import SlabSpec
    from cli.commands._options import keyed_fields
    argv = ["--seed", str(seed)]
    for f in keyed_fields(SlabSpec):
        value, flag = getattr(args, f.name), option(f.name)
        if isinstance(value, bool):
            argv.append(flag if value else "--no-" + flag[2:])
        elif value is not None and f.name != "seed":
            argv += [flag, repr(value) if isinstance(value, float) else str(value)]
    return argv


def _report(model, spec, s, out):
    print(f"{model} slab ({spec.scale}, seed {spec.seed}): {s['n_spheres']} spheres, "
          f"{s['n_fe_nodes']} FE nodes, {s['n_bridging_spheres']} bridging spheres, "
          f"{s['steps']} steps of {s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; "
          f"results in {out}")


def _seed_list(text):
    from argparse import ArgumentTypeError
    seeds = list_of(int, "integers")(text)
    if len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise ArgumentTypeError(f"distinct integers >= 0, got {text!r}")
    return seeds
