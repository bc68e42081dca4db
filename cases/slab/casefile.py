"""Slab case files (`kind = "slab"`): the keys are SlabSpec's fields (their tables in
SlabSpec's metadata), plus slab.model and the bars' [[reinforcement]] layers
(cases.reinforcement.Layer's keys; given, the slab is reinforced with them)."""
from dataclasses import fields

from cases.reinforcement import DIRECTIONS, FACES
from cases.slab.model import MODELS
from cases.slab.runs import run as run_model
from cases.slab.reinforced import checked_layers
from cases.slab.spec import SlabSpec
from orchestrator.casefile import (CASE, DENSITY, MODULUS, REQUIRED, STRENGTH, Key, choice,
                                   number, spec_from_case, spec_schema, within)

SCHEMA = {"case": CASE, **spec_schema(SlabSpec)}
# no default model, as for the `slab` command: full or coupled is the user's choice
SCHEMA["slab"] = {"model": Key(choice(*MODELS), REQUIRED), **SCHEMA["slab"]}
_LENGTH = Key(number, REQUIRED, within(0, 1, "m"))
SCHEMA["reinforcement"] = [{
    "diameter": _LENGTH, "spacing": _LENGTH, "cover": _LENGTH,
    "direction": Key(choice(*DIRECTIONS), REQUIRED), "face": Key(choice(*FACES)),
    "young": Key(number, check=MODULUS), "yield_strength": Key(number, check=STRENGTH),
    "density": Key(number, check=DENSITY), "bond_strength": Key(number, check=STRENGTH)}]


def check(data, folder, problems):
    """The layout of the bars (outside the concrete, crossing layers, ...) and a zone the
    model can have, one line each."""
    try:
        checked_layers(data["reinforcement"], False)
    except ValueError as e:
        problems.append(str(e))
    try:
        SlabSpec.zone_for(data["slab"]["model"], data["slab"].get("zone"), "slab.zone =")
    except ValueError as e:
        problems.append(str(e))


def spec(case):
    """The SlabSpec of a slab case (keys left out keep SlabSpec's defaults)."""
    model = case["slab"]["model"]
    zone = SlabSpec.zone_for(model, case["slab"].get("zone"), "slab.zone =")
    data = {**case.data, "slab": {**case.data["slab"], "zone": zone}}
    s = spec_from_case(SlabSpec, data, reinforcement=case.data["reinforcement"])
    keys = {f.name: f"{f.metadata['section']}.{f.metadata['name'] or f.name}"
            for f in fields(SlabSpec) if "kind" in f.metadata}
    inert = s.inert(model, [name for name, key in keys.items() if _given(data, key, name)])
    if inert:
        raise ValueError(f"{case.path}: {keys[inert[0]]} acts only on {inert[1]}; this case's "
                         f"model is {model!r}, zone {s.zone!r}, fe.material {s.fe_material!r}")
    return s


def _given(data, key, name):
    """Whether the case sets `key` (section.name) to other than SlabSpec's default."""
    section, field = key.split(".")
    return (field in data.get(section, {}) and
            data[section][field] != SlabSpec.__dataclass_fields__[name].default)


def run(case, out, force=False, quiet=False, resume=False):
    from orchestrator.run.folder import start_folder
    start = None if resume else (lambda: start_folder(case, out, force))
    return run_model(spec(case), case["slab"]["model"], out, quiet=quiet, resume=resume,
                     start=start)
