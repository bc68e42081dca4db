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
        spec, model = spec_from_args(slab.SlabSpec, args), args.model
    else:
        raise ValueError("give --out DIR for a new run, or --resume DIR")
    comm = MPI.COMM_WORLD
    if comm.size > 1:
        # under mpirun the FE model is distributed; YADE and the coupling stay on rank 0
        if model != "coupled":
            raise ValueError(f"--model {model} has no FE part: run it without mpirun")
        if spec.zone == "auto":
            raise ValueError("--zone auto rebuilds the FE model at each attempt: run it "
                             "without mpirun")
        if comm.rank > 0:
            from fenicsx_side.distributed import serve
            grid = slab.slab_grid(spec)
            serve(slab.fe_model(spec, grid, slab.fe_weight(spec, grid)))
            return 0
    from pathlib import Path
    from yade_side import import_yade
    import_yade(args.threads)
    out = Path(args.resume) if args.resume else prepare_out(args.out, args.force)
    s = slab.run(spec, model, out, quiet=args.quiet, resume=bool(args.resume))
    if s.get("zone_outcome") == "limit" and "n_spheres" not in s:
        return 1                # the one line saying why was printed
    print(f"{model} slab ({spec.scale}): {s['n_spheres']} spheres, {s['n_fe_nodes']} FE "
          f"nodes, {s['n_bridging_spheres']} bridging spheres, {s['steps']} steps of "
          f"{s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; results in {out}")
    return 0
