"""Case files: a coupled run described in TOML, checked before anything runs.

`load(path, overrides)` reads the file, applies `--set key=value` overrides and checks every key
against the schema below: unknown keys, wrong types, out-of-range values and inconsistent
combinations are all collected and reported together, one line per problem naming the key and
the value (`CaseError`, a ValueError). The result is a `Case`: the checked tables with their
defaults filled in. Checks that need the models built (a DE zone outside a gmsh mesh,
bridging spheres outside every FE element, a time step above a critical step) are made by
`orchestrator.case` before the first step. Every key is documented in docs/case-files.md.

Three kinds of case: `generic` (packing or user YADE script, box or gmsh mesh: see
orchestrator.case), `slab`, whose keys map onto cases.slab.SlabSpec, and `wave1d`, whose keys
are the `wave1d` command's options.
"""
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

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
def _number(v):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    return (float(v), None) if ok else (None, "a finite number")


def _integer(v):
    return (v, None) if isinstance(v, int) and not isinstance(v, bool) else (None, "an integer")


def _boolean(v):
    return (v, None) if isinstance(v, bool) else (None, "true or false")


def _string(v):
    return (v, None) if isinstance(v, str) else (None, "a string")


def _vector(v):
    if isinstance(v, list) and len(v) == 3 and all(_number(x)[1] is None for x in v):
        return [float(x) for x in v], None
    return None, "a list of 3 numbers"


def _divisions(v):
    if isinstance(v, list) and len(v) == 3 and all(_integer(x)[1] is None and x > 0 for x in v):
        return v, None
    return None, "a list of 3 positive integers"


def _axes(v):
    if (isinstance(v, list) and 1 <= len(v) <= 3 and len(set(v)) == len(v)
            and all(_integer(x)[1] is None and x in (0, 1, 2) for x in v)):
        return sorted(v), None
    return None, "a list of distinct axes among 0, 1, 2"


def _components(v):
    if isinstance(v, list) and v and all(x in AXIS for x in v) and len(set(v)) == len(v):
        return v, None
    return None, 'a non-empty list of distinct components among "x", "y", "z"'


def _strings(v):
    return (v, None) if isinstance(v, list) and all(isinstance(x, str) for x in v) \
        else (None, "a list of strings")


def _relaxation(v):
    return ("auto", None) if v == "auto" else (
        _number(v) if _number(v)[1] is None else (None, 'a number or "auto"'))


def choice(*options):
    def check(v):
        return (v, None) if v in options else (None, f"one of {', '.join(map(repr, options))}")
    return check


def positive(v):
    return None if v > 0 else "> 0"


def non_negative(v):
    return None if v >= 0 else ">= 0"


def at_least_one(v):
    return None if v >= 1 else ">= 1"


def poisson_range(v):
    return None if -1 < v < 0.5 else "in (-1, 0.5)"


def safety_range(v):
    return None if 0 < v <= 1 else "in (0, 1]"


@dataclass
class Key:
    kind: object
    default: object = UNSET
    check: object = None
    doc: str = ""


# --- the schema -----------------------------------------------------------------------------
CASE = {"name": Key(_string, REQUIRED), "kind": Key(choice("generic", "slab", "wave1d"), "generic"),
        "description": Key(_string, "")}
MATERIAL = {
    "young": Key(_number, 31e9, positive), "poisson": Key(_number, 0.2, poisson_range),
    "density": Key(_number, 2400.0, positive),
    "compressive_strength": Key(_number, 31e6, positive),
    "tensile_strength": Key(_number, 4.0e6, positive),
}
CPM = {name: Key(_number, UNSET, positive) for name in
       ("young", "poisson", "frictionAngle", "sigmaT", "epsCrackOnset", "relDuctility")}
PACKING = {"name": Key(_string, UNSET), "lo": Key(_vector, REQUIRED), "hi": Key(_vector, REQUIRED),
           "radius": Key(_number, REQUIRED, positive), "seed": Key(_integer, 1, non_negative),
           "velocity": Key(_vector, [0.0, 0.0, 0.0])}
DIRICHLET = {"face": Key(choice(*FACES), REQUIRED), "components": Key(_components, REQUIRED)}
SENSOR = {"name": Key(_string, REQUIRED), "point": Key(_vector, UNSET),
          "sphere": Key(_integer, UNSET, non_negative), "on": Key(choice("auto", "de", "fe"), "auto")}
OUTPUT = {"every": Key(_integer, 200, at_least_one), "sample_every": Key(_integer, 5, at_least_one),
          "check_every": Key(_integer, 50, at_least_one),
          "checkpoint_every": Key(_integer, 1000, at_least_one)}

GENERIC = {
    "case": CASE,
    "de": {"script": Key(_string, UNSET), "script_args": Key(_strings, []),
           "packing": [PACKING]},
    "material": dict(MATERIAL, cpm=CPM),
    "fe": {"mesh": Key(_string, "box"), "lo": Key(_vector, UNSET), "hi": Key(_vector, UNSET),
           "n": Key(_divisions, UNSET), "cell": Key(choice("hexahedron", "tetrahedron"), "hexahedron"),
           "dirichlet": [DIRICHLET]},
    "coupling": {"zone_lo": Key(_vector, REQUIRED), "zone_hi": Key(_vector, REQUIRED),
                 "zone_axes": Key(_axes, [0, 1]), "layers": Key(_integer, 3, at_least_one),
                 "element_size": Key(_number, UNSET, positive),
                 "variant": Key(choice("full", "diagonal"), "diagonal"),
                 "relaxation": Key(_relaxation, "auto", positive),
                 "rotations": Key(_boolean, True)},
    "time": {"dt_safety": Key(_number, 0.3, safety_range), "dt": Key(_number, UNSET, positive),
             "duration": Key(_number, UNSET, positive), "steps": Key(_integer, UNSET, at_least_one)},
    "sensors": [SENSOR],
    "output": OUTPUT,
}
# slab and wave1d: unset keys take the case module's defaults (SlabSpec, Wave1DSpec)
_unset = lambda table: {k: Key(v.kind, UNSET, v.check) for k, v in table.items()}
SLAB = {
    "case": CASE,
    "slab": {"model": Key(choice("coupled", "full"), "coupled"),
             "scale": Key(choice("small", "medium", "paper"), UNSET),
             "radius": Key(_number, UNSET, positive), "de_zone": Key(_number, UNSET, positive),
             "fe_ratio": Key(_number, UNSET, positive),
             "fe_ratio_thickness": Key(_number, UNSET, positive),
             "impactor_side": Key(_number, UNSET, positive),
             "impactor_speed": Key(_number, UNSET, positive),
             "impactor_gap": Key(_number, UNSET, non_negative),
             "full_width": Key(_boolean, UNSET),
             "elastic_outside": Key(_boolean, UNSET)},
    "material": _unset(MATERIAL),
    "coupling": {"layers": Key(_integer, UNSET, at_least_one),
                 "variant": Key(choice("full", "diagonal"), UNSET),
                 "relaxation": Key(_relaxation, UNSET, positive),
                 "rotations": Key(_boolean, UNSET)},
    "time": {"dt_safety": Key(_number, UNSET, safety_range),
             "steps": Key(_integer, UNSET, at_least_one)},
    "output": _unset(OUTPUT),
}
# wave1d: the options of the `wave1d` command (orchestrator.commands.wave1d); unset keys
# keep the command's defaults
WAVE1D = {
    "case": CASE,
    "coupling": {"layers": Key(_integer, UNSET, at_least_one),
                 "variant": Key(choice("full", "diagonal"), UNSET),
                 "relaxation": Key(_relaxation, UNSET, positive)},
    "wave1d": {"ratio": Key(_integer, UNSET, at_least_one)},
    "time": {"dt_safety": Key(_number, UNSET, safety_range)},
}
SCHEMAS = {"generic": GENERIC, "slab": SLAB, "wave1d": WAVE1D}


@dataclass
class Case:
    path: Path       # the case file
    kind: str
    data: dict       # checked tables, defaults filled in; paths resolved

    def __getitem__(self, section):
        return self.data[section]


def load(path, overrides=()):
    """Read and check a case file; `overrides` are "dotted.key=TOML value" strings (--set)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"case file {path} not found")
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"case file {path} is not valid TOML: {e}") from None
    problems = []
    for item in overrides:
        _override(raw, item, problems)
    if not isinstance(raw.setdefault("case", {}), dict):
        raise CaseError(path, [f"case = {raw['case']!r}: expected a table ([case])"])
    raw["case"].setdefault("name", path.stem)
    kind = raw["case"].get("kind", "generic")
    if kind not in SCHEMAS:
        raise CaseError(path, [f"case.kind = {kind!r}: expected one of {tuple(SCHEMAS)}"])
    data = _check_table(raw, SCHEMAS[kind], "", problems)
    if kind == "generic" and not problems:
        _check_generic(data, path.parent, problems)
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


def _check_generic(d, folder, problems):
    """Consistency of a generic case: one DE model, a usable mesh, a zone inside it."""
    de, fe, cp, time = d["de"], d["fe"], d["coupling"], d["time"]
    if ("script" in de) == bool(de["packing"]):
        problems.append("de: give either de.script (a YADE script) or [[de.packing]] boxes, "
                        f"not {'both' if 'script' in de else 'neither'}")
    if "script" in de:
        de["script"] = _existing(folder, de["script"], "de.script", problems)
        for key in d["material"]["cpm"]:
            problems.append(f"material.cpm.{key}: only for built-in packings (the script "
                            f"makes its own materials)")
    for i, p in enumerate(de["packing"]):
        _box_order(p["lo"], p["hi"], f"de.packing[{i}]", problems)
    _box_order(cp["zone_lo"], cp["zone_hi"], "coupling.zone", problems, cp["zone_axes"])
    if ("duration" in time) == ("steps" in time):
        problems.append("time: give either time.duration (s) or time.steps, not "
                        f"{'both' if 'steps' in time else 'neither'}")
    for i, s in enumerate(d["sensors"]):
        if ("point" in s) == ("sphere" in s):
            problems.append(f"sensors[{i}] ({s['name']!r}): give either point or sphere")
        elif "sphere" in s and s["on"] == "fe":
            problems.append(f"sensors[{i}].on = 'fe': a sphere sensor is on the DE side")
    names = [s["name"] for s in d["sensors"]]
    for n in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"sensors: two sensors are named {n!r}")
    if fe["mesh"] == "box":
        missing = [k for k in ("lo", "hi", "n") if k not in fe]
        if missing:
            problems.append(f"fe.mesh = 'box' needs fe.{', fe.'.join(missing)}")
            return
        if _box_order(fe["lo"], fe["hi"], "fe", problems):
            _zone_on_box(fe, cp, problems)
    else:
        for k in ("lo", "hi", "n"):
            if k in fe:
                problems.append(f"fe.{k}: only for fe.mesh = 'box' (the mesh is {fe['mesh']!r})")
        fe["mesh"] = _existing(folder, fe["mesh"], "fe.mesh", problems)
        if "element_size" not in cp:
            problems.append("coupling.element_size: required with a gmsh mesh (the bridging "
                            "width is layers × element_size)")


def _existing(folder, name, key, problems):
    path = (folder / name).resolve()
    if not path.is_file():
        problems.append(f"{key} = {name!r}: file {path} not found")
    return str(path)


def _box_order(lo, hi, key, problems, axes=(0, 1, 2)):
    bad = [a for a in axes if not hi[a] > lo[a]]
    if bad:
        problems.append(f"{key}: hi {hi} must exceed lo {lo} along axis {bad[0]}")
    return not bad


def _zone_on_box(fe, cp, problems):
    """The DE zone is cut out of the box mesh: inside it, on its grid planes, and with room
    for the bridging layers; the bridging width defaults to layers × element size."""
    lo, hi, n = np.array(fe["lo"]), np.array(fe["hi"]), np.array(fe["n"])
    h = (hi - lo) / n
    axes = cp["zone_axes"]
    for bound in ("zone_lo", "zone_hi"):
        z = np.array(cp[bound])
        for a in axes:
            if not lo[a] <= z[a] <= hi[a]:
                problems.append(f"coupling.{bound}[{a}] = {z[a]!r}: the DE zone is outside the "
                                f"mesh, which spans [{lo[a]!r}, {hi[a]!r}] along axis {a}")
                continue
            i = (z[a] - lo[a]) / h[a]
            if abs(i - round(i)) > 1e-9:
                problems.append(f"coupling.{bound}[{a}] = {z[a]!r}: not on a grid plane of the "
                                f"box mesh (nearest: {lo[a] + math.floor(i) * h[a]!r}, "
                                f"{lo[a] + math.ceil(i) * h[a]!r})")
    if "element_size" not in cp:
        sizes = {round(h[a], 12) for a in axes}
        if len(sizes) > 1:
            problems.append(f"coupling.element_size: required, the box's elements differ along "
                            f"the zone axes {axes} (sizes {sorted(sizes)})")
            return
        cp["element_size"] = float(h[axes[0]])
