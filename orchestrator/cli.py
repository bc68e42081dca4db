"""Command-line entry point: `python3 -m orchestrator SUBCOMMAND ...`.

Each module of `orchestrator.commands` is one subcommand: it defines `NAME`, `HELP`,
`configure(parser)` and `run(args) -> int`. Modules import the solvers inside `run`
only, so that `--help` stays fast.
"""
import argparse
import sys
import importlib
import pkgutil

from orchestrator import commands


def _command_modules():
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            yield importlib.import_module(f"{commands.__name__}.{info.name}")


def build_parser():
    parser = argparse.ArgumentParser(
        prog="python3 -m orchestrator",
        description="Coupled YADE (DE) / FEniCSx (FE) solver for impacts on concrete.")
    sub = parser.add_subparsers(dest="command", metavar="SUBCOMMAND", required=True)
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.configure(p)
        p.set_defaults(func=mod.run)
    return parser


# exit code of a run stopped by SIGTERM after writing its checkpoint (128 + SIGTERM)
STOPPED = 143


def main(argv=None):
    from orchestrator.run.guard import BlowUp
    from orchestrator.run.restart import Stopped
    from orchestrator.run.folder import ResultsExist
    from yade_side.checkpoint import CheckpointError
    args = build_parser().parse_args(argv)
    try:
        return args.func(args) or 0
    except Stopped as e:
        print(f"stopped: {e}", file=sys.stderr)
        return STOPPED
    except (ValueError, ResultsExist, BlowUp, FileNotFoundError, CheckpointError) as e:
        # bad input or a run that went wrong: one clear line, no traceback
        print(f"error: {e}", file=sys.stderr)
        return 2
