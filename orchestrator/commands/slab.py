"""`slab`: the paper's slab impact, full YADE or coupled YADE/FEniCSx."""
from orchestrator.commands._options import add_out, add_weighting, relaxation_arg

NAME = "slab"
HELP = "slab impact (paper §5): --model full|coupled --scale small|medium|paper"


def configure(p):
    p.add_argument("--model", choices=("full", "coupled"), default="coupled")
    p.add_argument("--scale", choices=("small", "medium", "paper"), default="small")
    p.add_argument("--steps", type=int, help="number of steps (default: per scale)")
    p.add_argument("--variant", choices=("full", "diagonal"), default="diagonal",
                   help="multiplier solver (default: diagonal)")
    p.add_argument("--relaxation", type=relaxation_arg, default=35.0,
                   help="relaxation r (default 35, the paper's), or 'auto': the 1D study's rule "
                        "(docs/wave1d.md)")
    add_weighting(p, "consistent")
    p.add_argument("--no-rotations", action="store_true", help="couple translations only")
    p.add_argument("--elastic-outside", action="store_true",
                   help="full model: links outside the coupled model's DE zone never damage, "
                        "as the coupled model assumes (compare shows the coupling error alone)")
    p.add_argument("--output-every", type=int, default=200, help="steps between ParaView frames")
    p.add_argument("--threads", type=int, default=None, help="YADE OpenMP threads")
    p.add_argument("--checkpoint-every", type=int, default=1000,
                   help="steps between checkpoints (default 1000)")
    p.add_argument("--resume", metavar="DIR",
                   help="carry on a stopped run from its checkpoint (other options are taken "
                        "from it)")
    add_out(p, "results folder", required=False)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args):
    from mpi4py import MPI
    from cases import slab
    from orchestrator.results import prepare_out
    if args.resume:
        from orchestrator.restart import read_meta
        info = read_meta(args.resume)["info"]
        spec, model, args.out = slab.SlabSpec(**info["spec"]), info["model"], args.resume
    elif args.out:
        spec = slab.SlabSpec(scale=args.scale, steps=args.steps, variant=args.variant,
                             relaxation=args.relaxation, weighting=args.weighting,
                             rotations=not args.no_rotations,
                             elastic_outside=args.elastic_outside,
                             output_every=args.output_every,
                             checkpoint_every=args.checkpoint_every)
        model = args.model
    else:
        raise ValueError("give --out DIR for a new run, or --resume DIR")
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        # under mpirun the FE model is distributed; YADE and the coupling stay on rank 0
        if model != "coupled":
            raise ValueError(f"--model {model} has no FE part: run it without mpirun")
        if comm.rank > 0:
            from fenicsx_side.distributed import serve
            serve(slab.fe_model(spec, slab.slab_grid(spec)))
            return 0
    from pathlib import Path
    from yade_side import import_yade
    import_yade(args.threads)
    out = Path(args.resume) if args.resume else prepare_out(args.out, args.force)
    s = slab.run(spec, model, out, quiet=args.quiet, resume=bool(args.resume))
    print(f"{model} slab ({spec.scale}): {s['n_spheres']} spheres, {s['n_fe_nodes']} FE "
          f"nodes, {s['n_bridging_spheres']} bridging spheres, {s['steps']} steps of "
          f"{s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; results in {out}")
    return 0
