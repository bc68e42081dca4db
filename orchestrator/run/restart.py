"""Checkpoints of a run, and carrying on from the last one (`--resume DIR`).

A checkpoint, `DIR/checkpoint/`, holds everything a run needs to go on as if it had never
stopped: the YADE scene with its CPM damage history (yade_side.checkpoint), the FE state
(u, v, t), the coupling's own state (the bridging spheres' accumulated rotations, the energy
exchange meter) and what the run loop has gathered (sensor histories, energies, damage maps,
the time split). Everything else (packing, FE mesh and operators, coupling matrices, initial
links, reference positions) is rebuilt from the case, deterministically, and checked against
the checkpoint's fingerprint before the state is loaded. A model with a state of its own
beyond those (`checkpoint_state()`: a zone grown during the run, orchestrator.run.grow) has it
kept beside them (`model.json`, `model.npz`), read back with `model_state` before the model
is rebuilt as it was. A checkpoint is written in a
temporary folder and swapped in by renames: a run killed at any moment leaves either the
previous checkpoint or the new one, whole.
"""
import json
import shutil
import signal
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.files import save_npz, write_json

CHECKPOINT = "checkpoint"


class Stopped(RuntimeError):
    """The run was asked to stop (SIGTERM, SIGINT) and left a checkpoint; `code` is the exit
    code (128 + the signal's number: 143, 130)."""

    def __init__(self, message, signum=signal.SIGTERM):
        super().__init__(message)
        self.code = 128 + int(signum)


@dataclass
class Record:
    """What the run loop has gathered up to step n."""
    n: int = 0
    times: list = field(default_factory=list)
    history: list = field(default_factory=list)   # (n_sensors, 3) per sample
    energy: list = field(default_factory=list)    # (t, E) per check
    maps_t: list = field(default_factory=list)
    maps: list = field(default_factory=list)      # damage per sphere per output
    gaps: list = field(default_factory=list)      # (t, constraint gap before, after) per check
    quantities: list = field(default_factory=list)  # the QoIs per sample (a case's, or none)
    seconds: dict = field(default_factory=dict)   # time split of the earlier run segments
    wall_s: float = 0.0                           # wall time of earlier run segments
    # the FE's largest cell σ1 over the samples and its time, then its largest von Mises and time
    fe_peak: list = field(default_factory=lambda: [0.0, 0.0, 0.0, 0.0])
    # the FE series file written now, and the output frame it starts at (a zone grown during
    # the run starts a file per FE mesh)
    fe_series: str = "fe.xdmf"
    fe_first: int = 0
    quantity_state: dict = field(default_factory=dict)   # what the QoIs carry between samples


# what a checkpoint of an earlier version lacks
EARLIER = {"fe_peak": "the FE's peak stress", "quantities": "the quantities of interest",
           "quantity_state_last": "the quantities' state",
           "fe_history_dissipated_cells": "the FE cells' dissipated energy"}


def add_splits(a, b):
    """Two time splits ({part: seconds}) added, part by part."""
    return {k: a.get(k, 0.0) + b.get(k, 0.0) for k in {*a, *b}}


def fingerprint(model, title, steps):
    """What a checkpoint must share with the rebuilt model to be loaded into it."""
    return {"title": title, "steps": int(steps), "dt": float(model.dt),
            "n_spheres": int(model.sphere_count()),
            "n_fe_nodes": 0 if model.fe is None else int(len(model.fe.nodes)),
            "n_bridging_spheres": int(len(model.bridge_index))}


def save(out, record, model, meta, seconds):
    """Write the checkpoint of step record.n into out/checkpoint, atomically; `seconds`: the
    run's time split so far."""
    from common import files
    from yade_side.checkpoint import save_scene
    out = Path(out)
    new, old, final = out / f".{CHECKPOINT}.new", out / f".{CHECKPOINT}.old", out / CHECKPOINT
    shutil.rmtree(new, ignore_errors=True)
    new.mkdir()
    for folder in (new, old, final):      # the project's, whatever a kill leaves of the swap
        files.record(folder)
    save_scene(new / "yade")
    state = {"n": record.n, "times": np.array(record.times),
             "history": np.array(record.history), "energy": np.array(record.energy).reshape(-1, 2),
             "maps_t": np.array(record.maps_t), "maps": np.array(record.maps),
             "gaps": np.array(record.gaps).reshape(-1, 3),
             "quantities": np.array(record.quantities),
             **{f"quantity_state_{k}": v for k, v in record.quantity_state.items()},
             "wall_s": record.wall_s, "fe_peak": np.array(record.fe_peak),
             "fe_series": np.array(record.fe_series), "fe_first": record.fe_first}
    if model.fe is not None:
        state.update(fe_u=model.fe.u, fe_v=model.fe.v, fe_t=model.fe.t,
                     **{f"fe_history_{k}": v for k, v in model.fe.history().items()})
    state.update({f"de_history_{k}": v for k, v in model.de_history().items()})
    stepper = model.stepper
    if stepper is not None:
        state.update(rotation=stepper.bridge.rotation, rotation_pred=stepper.bridge.rotation_pred,
                     **{f"exchange_{k}": v for k, v in stepper.exchange.state().items()})
    save_npz(new / "state.npz", **state)
    own = getattr(model, "checkpoint_state", None)
    if own is not None:
        info, arrays = own()
        write_json(new / "model.json", info)
        save_npz(new / "model.npz", **arrays)
    write_json(new / "meta.json", {**meta, "step": record.n, "seconds": seconds})
    if final.exists():
        # a run killed after its last swap can leave the checkpoint before it: stale now
        shutil.rmtree(old, ignore_errors=True)
        final.rename(old)
    new.rename(final)
    shutil.rmtree(old, ignore_errors=True)


def read_meta(out):
    """The meta.json of the checkpoint in run folder `out` (ValueError if there is none)."""
    folder = _folder(out)
    try:
        return json.loads((folder / "meta.json").read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{folder / 'meta.json'}: unreadable checkpoint file ({e})") from None


def model_state(out):
    """(info, arrays) a model's checkpoint_state() wrote into the checkpoint in run folder
    `out`; ValueError (one line) if there is none or it cannot be read."""
    folder = _folder(out)
    try:
        info = json.loads((folder / "model.json").read_text())
        with np.load(folder / "model.npz") as data:
            arrays = {k: data[k] for k in data.files}
    except FileNotFoundError as e:
        raise ValueError(f"{folder}: unreadable checkpoint file (no {Path(e.filename).name} in "
                         f"it: the model's own state)") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
        raise ValueError(f"{folder}: unreadable checkpoint file, the model's own state "
                         f"({e})") from None
    return info, arrays


def resume_meta(out):
    """read_meta of a run that can be resumed: refuses a finished one."""
    if (Path(out) / "summary.json").is_file():
        raise ValueError(f"{out} holds a finished run (summary.json): nothing to resume")
    return read_meta(out)


def check_inputs(out, inputs):
    """Refuse to carry on the checkpoint in `out` with other inputs than it was written with
    (orchestrator.run.inputs): ValueError naming each difference. Returns the meta.json."""
    from orchestrator.run.inputs import differences
    saved = read_meta(out)
    changed = differences(saved.get("inputs"), inputs or {})
    if changed:
        raise ValueError(f"{out}: the case changed since the checkpoint, and a resumed run "
                         f"would mix two models ({'; '.join(changed)}); restore it, or start "
                         f"a new run with --out")
    return saved


def load(out, model, meta, quantities=False):
    """Put the model in the state of the checkpoint in `out` and return its Record; raises
    ValueError, before touching the model, if the checkpoint is not of this model;
    `quantities`: the run records QoIs, which the checkpoint must hold."""
    from yade_side.checkpoint import load_scene
    folder = _folder(out)
    saved = check_inputs(out, meta.get("inputs"))
    mismatch = {k: (saved.get(k), v) for k, v in meta.items()
                if k not in ("info", "inputs") and saved.get(k) != v}
    if mismatch:
        raise ValueError(f"{folder} was written by another run: " + ", ".join(
            f"{k} {a!r} there, {b!r} here" for k, (a, b) in mismatch.items()))
    try:
        with np.load(folder / "state.npz") as data:
            state = {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
        raise ValueError(f"{folder / 'state.npz'}: unreadable checkpoint file ({e})") from None
    needed = ["n", "times", "history", "energy", "maps_t", "maps", "gaps", "wall_s", "fe_peak"]
    needed += (["fe_u", "fe_v", "fe_t"] + [f"fe_history_{k}" for k in model.fe.history()]
               if model.fe is not None else [])
    needed += ["rotation", "rotation_pred"] if model.stepper is not None else []
    needed += [f"de_history_{k}" for k in model.de_history()]
    needed += ["quantities", "quantity_state_last"] if quantities else []
    missing = [k for k in needed if k not in state]
    if missing and set(missing) <= set(EARLIER):
        raise ValueError(f"{folder / 'state.npz'}: a checkpoint of an earlier version, which did "
                         f"not record {' nor '.join(EARLIER[k] for k in missing)}: run it again "
                         f"from the start")
    if missing:
        raise ValueError(f"{folder / 'state.npz'}: unreadable checkpoint file (no "
                         f"{', '.join(missing)} in it)")
    load_scene(folder / "yade")
    if model.fe is not None:
        model.fe.u, model.fe.v, model.fe.t = state["fe_u"], state["fe_v"], float(state["fe_t"])
        model.fe.restore_history({k: state[f"fe_history_{k}"] for k in model.fe.history()})
    model.restore_de_history({k: state[f"de_history_{k}"] for k in model.de_history()})
    stepper = model.stepper
    if stepper is not None:
        stepper.bridge.rotation[:] = state["rotation"]
        stepper.bridge.rotation_pred[:] = state["rotation_pred"]
        stepper.exchange.restore({k[len("exchange_"):]: v for k, v in state.items()
                                  if k.startswith("exchange_")})
    return Record(int(state["n"]), list(state["times"]), list(state["history"]),
                  [tuple(e) for e in state["energy"]], list(state["maps_t"]),
                  list(state["maps"]), [tuple(g) for g in state["gaps"]],
                  list(state.get("quantities", [])), saved["seconds"],
                  float(state["wall_s"]), [float(v) for v in state["fe_peak"]],
                  str(state.get("fe_series", "fe.xdmf")), int(state.get("fe_first", 0)),
                  {k[len("quantity_state_"):]: v for k, v in state.items()
                   if k.startswith("quantity_state_")})


def _folder(out):
    folder = Path(out) / CHECKPOINT
    if not folder.is_dir():
        old = Path(out) / f".{CHECKPOINT}.old"  # killed between the two renames of save()
        if old.is_dir():
            return old
        raise ValueError(f"{out} has no checkpoint to resume from")
    return folder


class StopRequest:
    """While active, SIGTERM or SIGINT (Ctrl-C) asks the run to stop after the current step
    (with a checkpoint) instead of killing it; `signum` is the signal received."""
    SIGNALS = (signal.SIGTERM, signal.SIGINT)

    def __init__(self):
        self.signum = None

    @property
    def requested(self):
        return self.signum is not None

    def __enter__(self):
        self._previous = {s: signal.signal(s, self._handle) for s in self.SIGNALS}
        return self

    def __exit__(self, *_):
        for s, handler in self._previous.items():
            signal.signal(s, handler)

    def _handle(self, signum, _frame):
        self.signum = signum
