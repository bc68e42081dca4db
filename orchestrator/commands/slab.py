"""`slab`: the paper's slab impact, full YADE or coupled YADE/FEniCSx. Every option but the
model, threads and folders is a field of cases.slab.SlabSpec, which holds the defaults."""
from orchestrator.commands._options import add_out, add_spec_options, add_threads, spec_from_args

NAME = "slab"
HELP = "slab impact (paper §5): --model full|coupled --scale small|medium|paper"


def configure(p):
    from cases.slab import MODELS, SlabSpec
    p.add_argument("--model", choices=MODELS, default=None,
                   help="full: the whole slab in spheres; coupled: DE zone + FE "
                        "(required for a new run)")
    add_spec_options(p, SlabSpec)
    add_threads(p)
    p.add_argument("--resume", metavar="DIR",
                   help="carry on a stopped run from its checkpoint (other options are taken "
                        "from it)")
    add_out(p, "results folder", required=False)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args):
    from dataclasses import fields
    from pathlib import Path
    from mpi4py import MPI
    from cases import slab
    from orchestrator.run import folder
    if args.resume:
        given = [f"--{f.name.replace('_', '-')}" for f in fields(slab.SlabSpec)
                 if getattr(args, f.name, None) is not None]
        given += [o for o, v in (("--model", args.model), ("--out", args.out),
                                 ("--force", args.force)) if v]
        if given:
            raise ValueError(f"--resume DIR takes the slab and its folder from DIR's "
                             f"checkpoint: give no {', '.join(given)} with it")
        from orchestrator.run.restart import resume_meta
        info = resume_meta(args.resume)["info"]
        if "spec" not in info or "model" not in info:
            raise ValueError(f"{args.resume} holds a checkpoint of case {info.get('case')!r}, "
                             f"not of a slab run: resume it with `run --resume`")
        spec, model = slab.SlabSpec(**info["spec"]), info["model"]
    elif args.out and args.model:
        spec, model = spec_from_args(slab.SlabSpec, args), args.model
        folder.check_out(args.out, args.force)      # refuse before building, not after
    else:
        raise ValueError("give --model full|coupled and --out DIR for a new run, or --resume DIR")
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
    from yade_side import import_yade
    import_yade(args.threads)
    if args.resume:
        out, start = Path(args.resume), None
        folder.resume_folder(out)
    else:
        out, start = Path(args.out), lambda: folder.prepare_out(args.out, args.force)
    s = slab.run(spec, model, out, quiet=args.quiet, resume=bool(args.resume), start=start)
    print(f"{model} slab ({spec.scale}): {s['n_spheres']} spheres, {s['n_fe_nodes']} FE "
          f"nodes, {s['n_bridging_spheres']} bridging spheres, {s['steps']} steps of "
          f"{s['dt']:.3g} s, {s['s_per_step'] * 1e3:.2f} ms/step; results in {out}")
    return 0
