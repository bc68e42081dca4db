"""Sphere packings: YADE's random dense packing of boxes, deterministic and cached exactly.

A packing is YADE's `randomDensePack` with a periodic cell: a cloud of `spheres_in_cell` spheres
is compacted in a periodic cell whose proportions are the box's, then the cell is tiled over the
box and the spheres that lie wholly inside it are kept. The compaction is the costly part, so the
compacted cell is cached, one .npz file per cell, named by a hash of everything that defines it
(radius, radius fuzz, seed, spheres per cell, the box's proportions, YADE's version and
`ALGORITHM`). A cached cell is used only if it is exactly that cell; tiling it reproduces
`randomDensePack` bit for bit (tests/test_packing.py).

YADE's own memo (`memoizeDb`) is not used as a cache: it reuses any stored cell whose radius can be
scaled to the request, whatever its seed, so a packing depended on what had run before.

The compaction runs in a child process with one OpenMP thread: with two threads the contact
forces are summed in a varying order and the same seed gives different cells.
"""
import hashlib
import json
import os
import pickle
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from common.files import cache_folder, save_npz
from yade_side import import_yade

SPHERES_IN_CELL = 2000
# Bump when the way a cell is made changes, so that older cached cells are no longer used.
ALGORITHM = "randomDensePack-periodic/1"
_ROOT = Path(__file__).resolve().parents[1]
# Cells shipped with the project (the ones `make test` and `make run` use), read when the cache
# lacks them: a fresh machine does not spend minutes compacting them. The same exact-key check
# applies; tests/test_packing.py compacts each afresh and compares them bit for bit (slow).
SHIPPED = Path(__file__).resolve().parent / "cells"


def cache_dir():
    """Where the packings are cached (common.files.cache_folder): its folder cells/ is made."""
    return cache_folder("cells").parent


def dense_box_packing(lo, hi, radius, rel_fuzz=0.0, seed=1, spheres_in_cell=SPHERES_IN_CELL):
    """A random dense packing (φ ≈ 0.54–0.6) of spheres of `radius` (± rel_fuzz·radius, uniform)
    in the box [lo, hi], as a YADE SpherePack. The same arguments give the same spheres, bit for
    bit, whatever ran before; another `seed` gives another realisation."""
    import_yade()
    from yade import pack
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if not radius > 0:
        raise ValueError(f"sphere radius must be > 0, got {radius!r}")
    if not 0 <= rel_fuzz < 1:
        raise ValueError(f"relative radius fuzz must be in [0, 1), got {rel_fuzz!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"packing seed must be an integer >= 0, got {seed!r}")
    if isinstance(spheres_in_cell, bool) or not isinstance(spheres_in_cell, (int, np.integer)) \
            or spheres_in_cell < 10:
        raise ValueError(f"spheres_in_cell must be an integer >= 10, got {spheres_in_cell!r}")
    if np.any(hi - lo < 4 * radius):
        raise ValueError(f"box {lo.tolist()}–{hi.tolist()} is thinner than 4 sphere radii "
                         f"({radius!r}) on some axis")
    dim = hi - lo
    centres, radii, cell_size = periodic_cell(cell_key(dim, radius, rel_fuzz, seed,
                                                       spheres_in_cell))
    sp = pack.SpherePack([(tuple(c), float(r)) for c, r in zip(centres, radii)])
    sp.cellSize = tuple(cell_size)
    sp.cellFill(tuple(dim))
    return pack.filterSpherePack(pack.inAlignedBox(tuple(lo), tuple(hi)), sp, returnSpherePack=True)


def cell_key(dim, radius, rel_fuzz, seed, spheres_in_cell):
    """Everything that defines the periodic cell of a box of size `dim`: randomDensePack sizes the
    cell from the box's proportions only."""
    yade = import_yade()
    return {"algorithm": ALGORITHM, "yade": yade.config.version, "radius": float(radius),
            "rel_fuzz": float(rel_fuzz), "seed": int(seed), "spheres_in_cell": int(spheres_in_cell),
            "proportions": [float(dim[1] / dim[0]), float(dim[2] / dim[0])]}


def cell_path(key):
    """The cache file of the periodic cell defined by `key` (see dense_box_packing)."""
    name = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:24]
    return cache_dir() / "cells" / f"{name}.npz"


def periodic_cell(key):
    """(centres, radii, cell size) of the compacted periodic cell `key`: from the cache if it holds
    exactly that cell, else from the shipped cells, else compacted afresh and cached. An
    unreadable or mismatching file is passed over with a warning (the cell is deterministic, so
    the rebuild gives what the file should have held)."""
    path = cell_path(key)
    for where, what, then in ((path, "packing cache file", "rebuilding it"),
                              (SHIPPED / path.name, "shipped packing cell", "compacting it")):
        if where.exists():
            try:
                return _read_cell(where, key)
            except ValueError as err:
                print(f"warning: {what} {where} is unusable, {then}: {err}", file=sys.stderr)
    _compact_in_child(key, path)
    return _read_cell(path, key)


def _read_cell(path, key):
    try:
        with np.load(path, allow_pickle=False) as f:
            stored, centres, radii, size = str(f["key"]), f["centres"], f["radii"], f["cell_size"]
    except Exception as err:  # zip, npy or missing-array errors alike: the file is unusable
        raise ValueError(f"unreadable ({type(err).__name__}: {err})".splitlines()[0]) from None
    if stored != json.dumps(key, sort_keys=True):
        raise ValueError(f"it holds another cell ({stored[:80]})")
    n = key["spheres_in_cell"]
    if centres.shape != (n, 3) or radii.shape != (n,) or size.shape != (3,):
        raise ValueError(f"shapes {centres.shape}, {radii.shape}, {size.shape} do not hold "
                         f"{n} spheres")
    if not (np.all(np.isfinite(centres)) and np.all(radii > 0) and np.all(size > 0)):
        raise ValueError("non-finite centres or non-positive radii or cell size")
    return centres, radii, size


def _compact_in_child(key, path):
    """Compact the cell in a fresh one-thread process (see the module's docstring)."""
    env = dict(os.environ, OMP_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join([str(_ROOT)] + [p for p in [os.environ.get("PYTHONPATH")]
                                                          if p]))
    done = subprocess.run([sys.executable, "-m", "yade_side.packing", json.dumps(key), str(path)],
                          env=env, capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise RuntimeError(f"compacting the packing cell {path.name} failed: {last}")


def _compact(key, path):
    """In the child: YADE's randomDensePack for a box of the key's proportions, with a private,
    empty memo database, only to read back the compacted cell it stores there."""
    import_yade(threads=1)
    from yade import pack
    box = (1.0, *key["proportions"])
    with tempfile.TemporaryDirectory() as tmp:
        db = os.path.join(tmp, "cell.sqlite")
        pack.randomDensePack(pack.inAlignedBox((0, 0, 0), box), radius=key["radius"],
                             rRelFuzz=key["rel_fuzz"], spheresInCell=key["spheres_in_cell"],
                             seed=key["seed"], memoizeDb=db, returnSpherePack=True)
        with sqlite3.connect(db) as conn:
            rows = conn.execute("select dimx, dimy, dimz, pack from packings").fetchall()
    if len(rows) != 1:
        raise RuntimeError(f"expected one compacted cell in YADE's memo, found {len(rows)}")
    *size, blob = rows[0]
    spheres = pickle.loads(blob)
    centres = np.array([tuple(c) for c, _ in spheres], float).reshape(-1, 3)
    radii = np.array([r for _, r in spheres], float)
    save_npz(path, key=json.dumps(key, sort_keys=True), centres=centres, radii=radii,
             cell_size=np.array(size, float))


def sphere_arrays(sp):
    """(centres (n, 3), radii (n,)) of a SpherePack."""
    data = [(c[0], c[1], c[2], r) for c, r in sp]
    a = np.array(data, float).reshape(-1, 4)
    return a[:, :3], a[:, 3]


GREY = (0.6, 0.6, 0.6)


def add_spheres(centres, radii, material):
    """Append spheres to the scene; returns their ids as an int array."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    # a colour given: YADE's random one costs 14 µs a sphere (it reseeds Python's random)
    ids = O.bodies.append([utils.sphere(tuple(c), float(r), material=material, color=GREY)
                           for c, r in zip(centres, radii)])
    return np.asarray(ids, dtype=int)


def growth_groups(centres, keeps):
    """The indices of `centres` that each mask keeps(centres) adds to the ones before it, in
    order (a DE zone's growth)."""
    groups = []
    for keep in keeps:
        groups.append(added_by(keep, centres, np.concatenate(groups) if groups else []))
    return groups


def added_by(keep, centres, placed):
    """The indices of `centres` that the mask keep(centres) holds and the indices `placed` do
    not; ValueError if it does not hold every placed one (a grown zone holds the earlier)."""
    inside = np.asarray(keep(centres), bool)
    was = np.zeros(len(centres), bool)
    was[np.asarray(placed, int)] = True
    if (was & ~inside).any():
        raise ValueError("a grown DE zone must hold every sphere of the zones before it")
    return np.flatnonzero(inside & ~was)


def packing_fraction(radii, volume):
    return float(np.sum(4.0 / 3.0 * np.pi * np.asarray(radii) ** 3) / volume)


if __name__ == "__main__":
    _compact(json.loads(sys.argv[1]), Path(sys.argv[2]))
