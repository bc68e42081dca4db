"""Saving and restoring the YADE scene for restarts, CPM damage history included.

`O.save` does not keep CpmPhys's state variables: omega, Fn, sigmaN, epsN,
relResidualStrength, kappaD, epsNPl, sigmaT, Fs, epsTPl and epsT are plain C++ members, not
serialised attributes, and Python can only read them (YADE 2023.02a). After `O.load` every
link would restart undamaged, with no shear strain: the concrete would heal. So the
checkpoint also stores those 19 doubles of every cohesive-frictional link and writes them back
after loading, straight into YADE's memory (yade_side.memory): their offset in the C++
object is found by matching the values Python reads, and every link is verified bit for
bit against Python's read-only view before anything is saved, and again after it is restored.

A restarted run then continues identically until a new contact forms: `O.save` keeps only
the real interactions, the collider makes its candidate pairs again after the load at the
end of the interaction container, and a candidate that becomes a contact there has its forces
summed in another order: a round-off difference (measured: docs/case-files.md, "Long runs").
"""
import zipfile
from pathlib import Path

import numpy as np

from common.files import save_npz
from yade_side import import_yade
from yade_side.bulk import reattach_all
from yade_side.memory import (WIDTH, CheckpointError, HistoryBlocks, check_version,
                               find_offset, histories)


def _cpm_links():
    yade = import_yade()
    return [i for i in yade.Omega().interactions
            if i.isReal and isinstance(i.phys, yade.wrapper.CpmPhys)]


def save_scene(folder):
    """Write the scene (`scene.yade.gz`) and the CPM history (`cpm_history.npz`) into `folder`
    (created; the caller makes the folder's appearance atomic)."""
    check_version(CheckpointError)
    O = import_yade().Omega()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    links = _cpm_links()
    offset = find_offset(links)          # every link verified at it
    pairs = np.array([(i.id1, i.id2) for i in links], dtype=np.int64).reshape(-1, 2)
    history = (HistoryBlocks([i.phys for i in links], offset).read() if links
               else np.empty((0, WIDTH)))
    O.save(str(folder / "scene.yade.gz"))
    save_npz(folder / "cpm_history.npz", pairs=pairs, history=history,
             offset=-1 if offset is None else offset)


def load_scene(folder):
    """Replace the current scene by the one saved in `folder`, restore its CPM history and
    point every BodySet at the loaded bodies. Raises CheckpointError, and the run must not go
    on, if the files do not match."""
    check_version(CheckpointError)
    O = import_yade().Omega()
    folder = Path(folder)
    for name in ("scene.yade.gz", "cpm_history.npz"):
        if not (folder / name).is_file():
            raise CheckpointError(f"checkpoint {folder} has no {name}")
    try:
        with np.load(folder / "cpm_history.npz") as data:
            pairs, history, offset = data["pairs"], data["history"], int(data["offset"])
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as e:
        raise CheckpointError(f"{folder / 'cpm_history.npz'}: unreadable checkpoint file "
                              f"({e})") from None
    try:
        O.load(str(folder / "scene.yade.gz"))
    except RuntimeError as e:
        raise CheckpointError(f"checkpoint {folder}: YADE cannot load the scene ({e})") from None
    links = _cpm_links()
    loaded = np.array([(i.id1, i.id2) for i in links], dtype=np.int64).reshape(-1, 2)
    if not np.array_equal(loaded, pairs):
        raise CheckpointError(f"checkpoint {folder}: the saved scene has {len(loaded)} CPM links "
                              f"and the history file {len(pairs)}, or in another order")
    if links:
        phys = [i.phys for i in links]
        blocks = HistoryBlocks(phys, offset)
        # the blocks must hold what Python reads (the constructor's values) before they are set
        bad = _first_differing(blocks.read(), histories(phys))
        if bad is not None:
            raise CheckpointError(f"checkpoint {folder}: CpmPhys of link {links[bad].id1}-"
                                  f"{links[bad].id2} does not have the saved layout (another "
                                  f"YADE build?)")
        blocks.write(history)
        bad = _first_differing(histories(phys), history)
        if bad is not None:
            raise CheckpointError(f"checkpoint {folder}: CPM history of link "
                                  f"{links[bad].id1}-{links[bad].id2} did not restore exactly")
    reattach_all()


def _first_differing(a, b):
    """The first row where the (n, WIDTH) arrays a and b differ in any bit, or None."""
    differ = (np.asarray(a, float).view(np.int64) != np.asarray(b, float).view(np.int64)).any(1)
    return int(np.argmax(differ)) if differ.any() else None
