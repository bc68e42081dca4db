"""Options several subcommands share, and the options made from a case description's fields
(cases.slab.SlabSpec, cases.wave1d.Wave1DSpec: their defaults stay in the description)."""
import argparse
import math
import tomllib
from dataclasses import MISSING, fields

from orchestrator.casefile import boolean, within
from orchestrator.coupling.bridging import WEIGHTINGS


def add_weighting(p, default):
    p.add_argument("--weighting", choices=WEIGHTINGS, default=default,
                   help="bridging weights: 'consistent' puts α, β inside the partners' masses "
                        "and stiffnesses (energy-conserving), 'nodal' is the paper's "
                        f"(default {default})")


def count(text):
    """An integer >= 1 (threads, runs at a time, steps, layers)."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def ranged(low, high, kind=float, low_open=True, high_open=False):
    """An argparse type: a finite `kind` (float or int) in its physical range from `low` to
    `high` (each end excluded when open), so that no NaN, inf or absurd value reaches YADE's
    or PETSc's C++."""
    check = within(low, high, low_open=low_open, high_open=high_open)

    def parse(word):
        try:
            value = kind(word)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or check(value):
            raise argparse.ArgumentTypeError(
                f"must be {'an integer' if kind is int else 'a finite number'} {check.text}, "
                f"got {word!r}")
        return value
    return parse


def add_threads(p, default=None):
    """--threads; default None: OMP_NUM_THREADS, else every core (yade_side.import_yade)."""
    text = "OMP_NUM_THREADS, else every core" if default is None else default
    p.add_argument("--threads", type=count, default=default,
                   help=f"YADE OpenMP threads (default: {text}; only 1 gives bit-identical "
                        f"results and restarts)")


def add_out(p, what="results folder", required=True):
    p.add_argument("--out", required=required, help=what)
    p.add_argument("--force", action="store_true",
                   help="replace an existing results folder of this project")


def add_spec_options(p, cls):
    """One option per case-file field of the description `cls` (`--field-name`); left out,
    the description's own default applies."""
    for f in keyed_fields(cls):
        m = f.metadata
        text = m["help"]
        if f.default is not None:
            text += f" (default: {f.default})"
        elif "default" not in text:             # the help says what a None default becomes
            text += " (default: per scale)"
        flag = option(f.name)
        if m["kind"] is boolean:
            p.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, help=text)
        else:
            p.add_argument(flag, type=_literal, default=None, metavar=f.name.upper(), help=text)


def spec_from_args(cls, args, **values):
    """An instance of `cls` from the options add_spec_options made (the description checks
    the values)."""
    values.update({f.name: getattr(args, f.name) for f in keyed_fields(cls)
                   if getattr(args, f.name) is not None})
    return cls(**values)


def option(name):
    """The command-line option of field `name`."""
    return "--" + name.replace("_", "-")


def list_of(cast, what):
    """An argparse type: a comma-separated list of `cast` values (`what` names them)."""
    def parse(text):
        try:
            return [cast(x) for x in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"a comma-separated list of {what}, got "
                                             f"{text!r}") from None
    return parse


def keyed_fields(cls):
    """The fields of `cls` that are case-file keys and options."""
    return [f for f in fields(cls) if "kind" in f.metadata and f.default is not MISSING]


def _literal(text):
    """A number, true/false or a string, as a case file would read it."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
