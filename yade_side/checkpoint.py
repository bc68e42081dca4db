"""Saving and restoring the YADE scene for restarts, CPM damage history included.

`O.save` does not keep CpmPhys's state variables: omega, Fn, sigmaN, epsN,
relResidualStrength, kappaD, epsNPl, sigmaT, Fs, epsTPl and epsT are plain C++ members, not
serialised attributes, and Python can only read them (YADE 2023.02a). After `O.load` every
link would restart undamaged, with no shear strain: the concrete would heal. So the
checkpoint also stores those 19 doubles of every cohesive-frictional link and writes them back
after loading, straight into YADE's memory (no C++ plugin can be built here): their offset in
the C++ object is found by matching the values Python reads, and every link is verified bit for
bit against Python's read-only view before anything is saved, and again after it is restored.

A restarted run then continues identically until the collider, which rebuilds its bounds on
load, lets a new contact into the interaction container at another place: forces on a sphere
are then summed in another order, a round-off difference (measured in tests/test_checkpoint.py).
"""
import ctypes
from pathlib import Path

import numpy as np

from yade_side import import_yade
from yade_side.bulk import reattach_all
from yade_side.state_memory import state_address

# CpmPhys members after the serialised base, in declaration order: 7 reals, 4 Vector3r
HISTORY = ("omega", "Fn", "sigmaN", "epsN", "relResidualStrength", "kappaD", "epsNPl",
           "sigmaT", "Fs", "epsTPl", "epsT")
WIDTH = 19
_SEARCH = 128  # doubles of a CpmPhys searched for the block


class CheckpointError(RuntimeError):
    pass


def history_values(phys):
    """The 19 history doubles of a CpmPhys, as Python reads them."""
    return np.concatenate([np.atleast_1d(np.asarray(getattr(phys, n), float)) for n in HISTORY])


def _block(phys, offset):
    return np.ctypeslib.as_array((ctypes.c_double * WIDTH).from_address(
        state_address(phys) + 8 * offset))


def _same(a, b):
    return np.array_equal(np.asarray(a, float).view(np.int64), np.asarray(b, float).view(np.int64))


def _cpm_links():
    yade = import_yade()
    return [i for i in yade.Omega().interactions
            if i.isReal and isinstance(i.phys, yade.wrapper.CpmPhys)]


def find_offset(links):
    """Offset (in doubles) of the history block inside CpmPhys, found on the link whose values
    are the most distinctive and verified on every link; CheckpointError if it cannot be."""
    if not links:
        return None
    probe = max(links, key=lambda i: np.count_nonzero(history_values(i.phys)))
    address = state_address(probe.phys)
    if address is None:
        raise CheckpointError("cannot locate CpmPhys in memory: unexpected boost.python layout")
    memory = np.ctypeslib.as_array((ctypes.c_double * _SEARCH).from_address(address)).copy()
    want = history_values(probe.phys)
    hits = [o for o in range(_SEARCH - WIDTH + 1) if _same(memory[o:o + WIDTH], want)]
    if len(hits) != 1:
        raise CheckpointError(f"CpmPhys history block found {len(hits)} times in memory; "
                              f"cannot checkpoint the CPM damage state")
    offset = hits[0]
    for i in links:
        if state_address(i.phys) is None or not _same(_block(i.phys, offset),
                                                       history_values(i.phys)):
            raise CheckpointError(f"CpmPhys of link {i.id1}-{i.id2} does not have the layout "
                                  f"found on the others; cannot checkpoint the CPM state")
    return offset


def save_scene(folder):
    """Write the scene (`scene.yade.gz`) and the CPM history (`cpm_history.npz`) into `folder`
    (created; the caller makes the folder's appearance atomic)."""
    O = import_yade().Omega()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    links = _cpm_links()
    offset = find_offset(links)
    pairs = np.array([(i.id1, i.id2) for i in links], dtype=np.int64).reshape(-1, 2)
    history = np.array([_block(i.phys, offset) for i in links]).reshape(-1, WIDTH)
    O.save(str(folder / "scene.yade.gz"))
    np.savez(folder / "cpm_history.npz", pairs=pairs, history=history,
             offset=-1 if offset is None else offset)


def load_scene(folder):
    """Replace the current scene by the one saved in `folder`, restore its CPM history and
    point every BodySet at the loaded bodies. Raises CheckpointError, and the run must not go
    on, if the files do not match."""
    O = import_yade().Omega()
    folder = Path(folder)
    for name in ("scene.yade.gz", "cpm_history.npz"):
        if not (folder / name).is_file():
            raise CheckpointError(f"checkpoint {folder} has no {name}")
    with np.load(folder / "cpm_history.npz") as data:
        pairs, history, offset = data["pairs"], data["history"], int(data["offset"])
    try:
        O.load(str(folder / "scene.yade.gz"))
    except RuntimeError as e:
        raise CheckpointError(f"checkpoint {folder}: YADE cannot load the scene ({e})") from None
    links = _cpm_links()
    loaded = np.array([(i.id1, i.id2) for i in links], dtype=np.int64).reshape(-1, 2)
    if not np.array_equal(loaded, pairs):
        raise CheckpointError(f"checkpoint {folder}: the saved scene has {len(loaded)} CPM links "
                              f"and the history file {len(pairs)}, or in another order")
    for link, values in zip(links, history):
        # the block must hold what Python reads (the constructor's values) before it is set
        if state_address(link.phys) is None or not _same(_block(link.phys, offset),
                                                          history_values(link.phys)):
            raise CheckpointError(f"checkpoint {folder}: CpmPhys of link {link.id1}-{link.id2} "
                                  f"does not have the saved layout (another YADE build?)")
        _block(link.phys, offset)[:] = values
        if not _same(history_values(link.phys), values):
            raise CheckpointError(f"checkpoint {folder}: CPM history of link "
                                  f"{link.id1}-{link.id2} did not restore exactly")
    reattach_all()
