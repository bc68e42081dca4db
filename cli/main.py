"""Command-line entry point: `python3 -m cli SUBCOMMAND ...`.

Each module of `cli.commands` is one subcommand: it defines `NAME`, `HELP`,
`configure(parser)` and `run(args) -> int`. Modules import the solvers inside `run`
only, so that `--help` stays fast.
"""
import sys
import importlib
import pkgutil

from cli import commands
from common.arguments import Parser


def _command_modules():
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            yield importlib.import_module(f"{commands.__name__}.{info.name}")


def build_parser():
    parser = Parser(
        prog="python3 -m cli",
        description="Coupled YADE (DE) / FEniCSx (FE) solver for impacts on concrete.")
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND", required=True)
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.configure(p)
        p.set_defaults(func=mod.run)
    return parser


# exit code of a run stopped by SIGTERM after writing its checkpoint (128 + SIGTERM); SIGINT
# (Ctrl-C) gives 130
STOPPED = 143
INTERRUPTED = 130


def main(argv=None):
    from orchestrator.run import folder
    from orchestrator.run.guard import BlowUp
    from orchestrator.run.loop import StepFailed
    from orchestrator.run.restart import Stopped
    from yade_side.checkpoint import CheckpointError
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:          # --help, or a command-line mistake already printed
        return e.code
    args.argv = list(sys.argv[1:] if argv is None else argv)     # to start again (cli.mpi)
    folder.forget()
    try:
        code = args.func(args) or 0
    except Stopped as e:
        folder.forget()            # the folder holds a checkpoint: --resume carries on
        print(f"stopped: {e}", file=sys.stderr)
        return e.code
    except KeyboardInterrupt:      # Ctrl-C outside the time loop (which checkpoints instead)
        folder.settle_failure("interrupted (Ctrl-C) before the run could checkpoint")
        print("interrupted", file=sys.stderr)
        return INTERRUPTED
    except (ValueError, folder.ResultsExist, BlowUp, StepFailed, OSError, CheckpointError) as e:
        # bad input or a run that went wrong: one clear line, no traceback
        folder.settle_failure(f"error: {e}")
        print(f"error: {e}", file=sys.stderr)
        return 2
    except Exception as e:         # a defect: the traceback is for us, the folder is marked
        folder.settle_failure(f"internal error: {type(e).__name__}: {e}")
        raise
    folder.forget()
    return code
