"""Case files: a run described in TOML, checked before anything runs.

`load(path, kinds, overrides)` reads the file, applies `--set key=value` overrides and checks
every key against the schema of the file's kind: unknown keys, wrong types, out-of-range
values and inconsistent combinations are all collected and reported together, one line per
problem naming the key and the value (`CaseError`, a ValueError). The result is a `Case`: the
checked tables with their defaults filled in. The kinds and their schemas are the cases'
(cases.kinds); checks that need the models built are made by the builder before the first
step. Every key is documented in docs/case-files.md.
"""
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from orchestrator.coupling.assembly import MIN_SAFETY
from orchestrator.coupling.relaxation import RELAXATION_RULES

UNSET = object()          # no default: the key is left out (the case module's default applies)
REQUIRED = object()
FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
AXIS = {"x": 0, "y": 1, "z": 2}


class CaseError(ValueError):
    def __init__(self, source, problems):
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"case file {source}: {len(self.problems)} problem"
                         f"{'s' if len(self.problems) > 1 else ''}:\n{lines}")


# --- value types: each returns (value, None) or (None, "what was expected") ---------------------
def number(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    return (float(v), None) if ok else (None, "a finite number")


def integer(v):
    return (v, None) if isinstance(v, int) and not isinstance(v, bool) else (None, "an integer")


def boolean(v):
    return (v, None) if isinstance(v, bool) else (None, "true or false")


def string(v):
    return (v, None) if isinstance(v, str) else (None, "a string")


def vector(v):
    if isinstance(v, list) and len(v) == 3 and all(number(x)[1] is None for x in v):
        return [float(x) for x in v], None
    return None, "a list of 3 numbers"


def divisions(v):
    if isinstance(v, list) and len(v) == 3 and all(integer(x)[1] is None and x > 0 for x in v):
        return v, None
    return None, "a list of 3 positive integers"


def axes(v):
    if (isinstance(v, list) and 1 <= len(v) <= 3 and len(set(v)) == len(v)
            and all(integer(x)[1] is None and x in (0, 1, 2) for x in v)):
        return sorted(v), None
    return None, "a list of distinct axes among 0, 1, 2"


def components(v):
    if isinstance(v, list) and v and all(x in AXIS for x in v) and len(set(v)) == len(v):
        return v, None
    return None, 'a non-empty list of distinct components among "x", "y", "z"'


def strings(v):
    return (v, None) if isinstance(v, list) and all(isinstance(x, str) for x in v) \
        else (None, "a list of strings")


def number_or_auto(v):
    return ("auto", None) if v == "auto" else (
        number(v) if number(v)[1] is None else (None, 'a number or "auto"'))


def relaxation_kind(v):
    """r: a number, or the rule that gives it (orchestrator.coupling.relaxation)."""
    return (v, None) if v in RELAXATION_RULES else (
        number(v) if number(v)[1] is None else (None, 'a number, "auto" or "rho"'))


def integer_or_auto(v):
    return ("auto", None) if v == "auto" else (
        integer(v) if integer(v)[1] is None else (None, 'an integer or "auto"'))


def choice(*options):
    def check(v):
        return (v, None) if v in options else (None, f"one of {', '.join(map(repr, options))}")
    return check


def positive(v):
    return None if v > 0 else "> 0"


def non_negative(v):
    return None if v >= 0 else ">= 0"


def within(low, high, unit="", low_open=True, high_open=False):
    """A check: low < v <= high (each end included or excluded as told): the physical range
    of a key or an option, so that no absurd value reaches YADE's or PETSc's C++; its text
    (`check.text`) says the range."""
    text = (f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
            f"{' ' + unit if unit else ''}")

    def check(v):
        return None if ((low < v if low_open else low <= v) and
                        (v < high if high_open else v <= high)) else text
    check.text = text
    return check


# physical ranges shared by the cases' keys
MODULUS = within(1e6, 1e12, "Pa")
STRENGTH = within(1e5, 1e9, "Pa")
DENSITY = within(100, 2e4, "kg/m³", low_open=False)
FRACTURE_ENERGY = within(0, 1e7, "J/m²")
SEED = within(0, 2**31 - 1, low_open=False)        # YADE's packings take a C int


MAX_STEPS = 10**9      # beyond, a run takes weeks (at >= 1 ms per step): a mistake


def step_count(v):
    return None if 1 <= v <= MAX_STEPS else f"in [1, {MAX_STEPS:.0e}] (steps of a run)"


def poisson_range(v):
    return None if -1 < v < 0.5 else "in (-1, 0.5)"


def safety_range(v):
    return None if MIN_SAFETY <= v <= 1 else f"in [{MIN_SAFETY:g}, 1] (× the critical step)"


@dataclass
class Key:
    kind: object
    default: object = UNSET
    check: object = None
    doc: str = ""


# --- case descriptions whose fields carry their case-file key (cases.slab.SlabSpec) ----------
def spec_key(default, kind, check=None, section="slab", name=None, help=""):
    """A dataclass field that is also the case-file key `section.name` (default: the field's
    name), checked by kind and check; `help` for the command-line option."""
    return field(default=default, metadata=dict(kind=kind, check=check, section=section,
                                                name=name, help=help))


def spec_schema(cls):
    """The case-file tables of a description class: {section: {key: Key}}, unset keys left
    to the class's defaults."""
    schema = {}
    for f in fields(cls):
        m = f.metadata
        if "kind" in m:
            schema.setdefault(m["section"], {})[m["name"] or f.name] = Key(m["kind"], UNSET,
                                                                            m["check"])
    return schema


def spec_from_case(cls, data, **extra):
    """An instance of `cls` from checked case-file tables (keys left out keep the defaults)."""
    values = {f.name: data[f.metadata["section"]][f.metadata["name"] or f.name]
              for f in fields(cls) if "kind" in f.metadata
              and (f.metadata["name"] or f.name) in data.get(f.metadata["section"], {})}
    return cls(**values, **extra)


def check_spec(spec, owner):
    """Check every keyed field of `spec` as the case file would (None: the default applies);
    ValueError "owner: name must be ..., got value"."""
    for f in fields(spec):
        m, value = f.metadata, getattr(spec, f.name)
        auto = value == "auto" and m.get("kind") in (number_or_auto, integer_or_auto)
        if "kind" not in m or value is None or auto:
            continue
        converted, expected = m["kind"](value)
        complaint = expected or (m["check"](converted) if m["check"] and
                                 not isinstance(converted, str) else None)
        if complaint:
            raise ValueError(f"{owner}: {f.name} must be {complaint}, got {value!r}")
        setattr(spec, f.name, converted)


# --- the schema -----------------------------------------------------------------------------
# the [case] table every kind shares (the kinds: cases.kinds)
CASE = {"name": Key(string, REQUIRED), "kind": Key(string, "generic"),
        "description": Key(string, "")}
OUTPUT = {"every": Key(integer, 200, step_count), "sample_every": Key(integer, 5, step_count),
          "check_every": Key(integer, 50, step_count),
          "checkpoint_every": Key(integer, 1000, step_count)}
@dataclass
class Kind:
    """A kind of case: its schema {table: {key: Key}}, and check(data, folder, problems) of
    what needs several keys at once (or None)."""
    schema: dict
    check: object = None


@dataclass
class Case:
    path: Path       # the case file
    kind: str
    data: dict       # checked tables, defaults filled in; paths resolved

    def __getitem__(self, section):
        return self.data[section]


def load(path, kinds, overrides=()):
    """Read and check a case file against its kind among `kinds` ({name: Kind}, see
    cases.kinds); `overrides` are "dotted.key=TOML value" strings (--set)."""
    from common.files import read_text
    path = Path(path)
    text = read_text(path, "case file")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"case file {path} is not valid TOML: {e}") from None
    problems = []
    for item in overrides:
        _override(raw, item, problems)
    if not isinstance(raw.setdefault("case", {}), dict):
        raise CaseError(path, [f"case = {raw['case']!r}: expected a table ([case])"])
    raw["case"].setdefault("name", path.stem)
    name = raw["case"]["name"]
    if isinstance(name, str) and (name.strip() in ("", ".", "..") or "/" in name
                                  or "\\" in name):
        problems.append(f"case.name = {name!r}: must be a plain folder name (it names the "
                        f"default results folder, results/<name>)")
    kind = raw["case"].get("kind", "generic")
    if kind not in kinds:
        raise CaseError(path, [f"case.kind = {kind!r}: expected one of {tuple(kinds)}"])
    data = _check_table(raw, kinds[kind].schema, "", problems)
    if kinds[kind].check is not None and not problems:
        kinds[kind].check(data, path.parent, problems)
    if problems:
        raise CaseError(path, problems)
    return Case(path, kind, data)


def _override(raw, item, problems):
    key, sep, text = item.partition("=")
    if not sep or not key.strip():
        problems.append(f"--set {item!r}: expected dotted.key=value")
        return
    try:
        value = tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        value = text          # a bare word is a string, as in batch parameter tables
    *tables, last = key.strip().split(".")
    node = raw
    for t in tables:
        node = node.setdefault(t, {})
        if not isinstance(node, dict):
            problems.append(f"--set {key}: {t} is not a table")
            return
    node[last] = value


def _check_table(raw, schema, prefix, problems):
    if not isinstance(raw, dict):
        problems.append(f"{prefix.rstrip('.') or 'file'}: expected a table, got {raw!r}")
        return {}
    out = {}
    for key in raw.keys() - schema.keys():
        problems.append(f"{prefix}{key}: unknown key (known here: {', '.join(sorted(schema))})")
    for key, spec in schema.items():
        name = f"{prefix}{key}"
        if isinstance(spec, dict):
            out[key] = _check_table(raw.get(key, {}), spec, f"{name}.", problems)
        elif isinstance(spec, list):
            items = raw.get(key, [])
            if not isinstance(items, list):
                problems.append(f"{name}: expected an array of tables ([[{name}]]), got {items!r}")
                items = []
            out[key] = [_check_table(t, spec[0], f"{name}[{i}].", problems)
                        for i, t in enumerate(items)]
        elif key in raw:
            value, expected = spec.kind(raw[key])
            if expected:
                problems.append(f"{name} = {raw[key]!r}: expected {expected}")
                continue
            complaint = spec.check(value) if spec.check and not isinstance(value, str) else None
            if complaint:
                problems.append(f"{name} = {raw[key]!r}: must be {complaint}")
                continue
            out[key] = value
        elif spec.default is REQUIRED:
            problems.append(f"{name}: missing (required)")
        elif spec.default is not UNSET:
            out[key] = spec.default
    return out
