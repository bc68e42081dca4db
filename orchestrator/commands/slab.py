"""`slab`: the paper's slab impact, full YADE or coupled YADE/FEniCSx. Every option but the
model, threads and folders is a field of cases.slab.SlabSpec, which holds the defaults."""
from orchestrator.commands._options import add_out, add_spec_options, spec_from_args

NAME = "slab"
HELP = "slab impact (paper §5): --model full|coupled --scale small|medium|paper"


def configure(p):
    from cases.slab import MODELS, SlabSpec
    p.add_argument("--model", choices=MODELS, default="coupled",
                   help="full: the whole slab in spheres; coupled (default): DE zone + FE")
    add_spec_options(p, SlabSpec)
    p.add_argument("--seeds", type=_seed_list, metavar="N,N,...",
                   help="an ensemble: one run per packing seed, in DIR/seed-N (instead of --seed)")
    p.add_argument("--threads", type=int, default=None, help="YADE OpenMP threads")
    p.add_argument("--resume", metavar="DIR",
                   help="carry on a stopped run from its checkpoint (other options are taken "
                        "from it)")
    add_out(p, "results folder", required=False)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args):
    from mpi4py import MPI
    from cases import slab
    from orchestrator.run.folder import prepare_out
    if args.resume:
        from orchestrator.run.restart import read_meta
        info = read_meta(args.resume)["info"]
        spec, model, args.out = slab.SlabSpec(**info["spec"]), info["model"], args.resume
    elif args.out:
        if args.seeds and args.seed is not None:
            raise ValueError("give either --seed or --seeds, not both")
        spec, model = spec_from_args(slab.SlabSpec, args), args.model
    else:
        raise ValueError("give --out DIR for a new run, or --resume DIR")
    if args.seeds:
        if MPI.COMM_WORLD.size > 1 or args.resume:
            raise ValueError("--seeds runs its members one after the other: not under mpirun, "
                             "and resume each member with --resume DIR/seed-N")
        return _ensemble(spec, model, args)
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        # under mpirun the FE model is distributed; YADE and the coupling stay on rank 0
        if model != "coupled":
            raise ValueError(f"--model {model} has no FE part: run it without mpirun")
        if comm.rank > 0:
            from fenicsx_side.distributed import serve
            grid = slab.slab_grid(spec)
            serve(slab.fe_model(spec, grid, slab.fe_weight(spec, grid)))
            return 0
    from pathlib import Path
    from yade_side import import_yade
    import_yade(args.threads)
    out = Path(args.resume) if args.resume else prepare_out(args.out, args.force)
    _report(model, spec, slab.run(spec, model, out, quiet=args.quiet, resume=bool(args.resume)),
            out)
    return 0


def _ensemble(spec, model, args):
    """One member per seed, one after the other in this process: DIR/seed-N."""
    from dataclasses import replace
    from cases import slab
    from orchestrator.run.folder import prepare_out
    from yade_side import import_yade
    import_yade(args.threads)
    top = prepare_out(args.out, args.force)
    for seed in args.seeds:
        member = replace(spec, seed=seed)
        out = prepare_out(top / f"seed-{seed}")
        _report(model, member, slab.run(member, model, out, quiet=args.quiet), out)
    return 0


def _report(model, spec, s, out):
    print(f"{model} slab ({spec.scale}, seed {spec.seed}): {s['n_spheres']} spheres, "
          f"{s['n_fe_nodes']} FE nodes, {s['n_bridging_spheres']} bridging spheres, "
          f"{s['steps']} steps of {s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; "
          f"results in {out}")


def _seed_list(text):
    from argparse import ArgumentTypeError
    try:
        seeds = [int(x) for x in text.split(",")]
    except ValueError:
        raise ArgumentTypeError(f"a comma-separated list of integers, got {text!r}") from None
    if len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise ArgumentTypeError(f"distinct integers >= 0, got {text!r}")
    return seeds
