"""What a run's results depend on, as flat {dotted key: value}: every key of its case (or
slab description) but those that cannot change a result, and the content of the files the
case reads. A checkpoint keeps them; a resumed run must have the same, or it would mix two
models in one set of results (orchestrator.run.restart names the differences)."""
import hashlib
import json
from dataclasses import MISSING, asdict, fields
from pathlib import Path

# keys that change no result: free text, how often the run checkpoints, how the run chose
# the dt_safety it records
IGNORED = {"case.description", "output.checkpoint_every", "checkpoint_every", "dt_choice"}
FILES = ("de.script", "fe.mesh")     # case keys naming a file whose content is an input


def flatten(data, prefix=""):
    """{dotted key: value} of nested tables; arrays of tables as key[i].sub."""
    flat = {}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten(value, f"{name}."))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, item in enumerate(value):
                flat.update(flatten(item, f"{name}[{i}]."))
        else:
            flat[name] = value
    return flat


def case_inputs(case):
    """The inputs of a generic case: its checked keys (defaults filled in) and the content of
    its script and mesh files."""
    flat = {k: v for k, v in flatten(case.data).items() if k not in IGNORED}
    for key in FILES:
        if flat.get(key, "box") != "box":
            flat[f"content of {key}"] = digest(flat[key])
    return flat


class Inputs(dict):
    """Inputs with the declared defaults of their keys (`defaults`): a key a checkpoint lacks
    (its field was added since) is the same input when it is at its default now."""
    defaults = {}


def spec_inputs(spec, model):
    """The inputs of a slab run: its model and every field of its description."""
    flat = {k: v for k, v in asdict(spec).items() if k not in IGNORED}
    inputs = Inputs(model=model, **flat)
    inputs.defaults = {k: v for k, v in declared_defaults(type(spec)).items() if k in flat}
    return inputs


def declared_defaults(cls):
    """{field: its declared default} of a description dataclass."""
    return {f.name: f.default for f in fields(cls) if f.default is not MISSING}


def digest(path):
    path = Path(path)
    return ("sha256:" + hashlib.sha256(path.read_bytes()).hexdigest()[:16]
            if path.is_file() else "missing")


def differences(saved, now):
    """One line per key whose value differs: 'key: A at the checkpoint, B now'; `saved` was
    read from the checkpoint's JSON, `now` goes through JSON too (tuples become lists); a key
    `saved` lacks counts at its declared default (Inputs)."""
    if saved is None:
        return ["the checkpoint does not record its case (written by an earlier version)"]
    defaults = json.loads(json.dumps(getattr(now, "defaults", {}), default=str))
    now = json.loads(json.dumps(now, default=str))
    saved = {**{k: v for k, v in defaults.items() if k in now}, **saved}
    missing = object()
    show = lambda v: "absent" if v is missing else repr(v)
    return [f"{key}: {show(saved.get(key, missing))} at the checkpoint, "
            f"{show(now.get(key, missing))} now"
            for key in sorted(saved.keys() | now.keys())
            if saved.get(key, missing) != now.get(key, missing)]
