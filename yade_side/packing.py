"""Sphere packings: YADE's random dense packing of boxes, memoized in a user cache."""
import os
from pathlib import Path

import numpy as np

from yade_side import import_yade


def cache_dir():
    """Where the periodic packings are memoized: $DEM_FEM_CACHE, else ~/.cache/…; never the repo."""
    path = Path(os.environ.get("DEM_FEM_CACHE", Path.home() / ".cache" / "yade-fenicsx-coupling"))
    path.mkdir(parents=True, exist_ok=True)
    return path


def dense_box_packing(lo, hi, radius, rel_fuzz=0.0, seed=1):
    """A random dense packing (φ ≈ 0.54–0.6) of spheres of `radius` in the box [lo, hi]."""
    import_yade()
    from yade import pack
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if not radius > 0:
        raise ValueError(f"sphere radius must be > 0, got {radius!r}")
    if np.any(hi - lo < 4 * radius):
        raise ValueError(f"box {lo.tolist()}–{hi.tolist()} is thinner than 4 sphere radii "
                         f"({radius!r}) on some axis")
    return pack.randomDensePack(pack.inAlignedBox(tuple(lo), tuple(hi)), radius=radius,
                                rRelFuzz=rel_fuzz, spheresInCell=2000, seed=seed,
                                memoizeDb=str(cache_dir() / "packings.sqlite"),
                                returnSpherePack=True)


def sphere_arrays(sp):
    """(centres (n, 3), radii (n,)) of a SpherePack."""
    data = [(c[0], c[1], c[2], r) for c, r in sp]
    a = np.array(data, float).reshape(-1, 4)
    return a[:, :3], a[:, 3]


def add_spheres(centres, radii, material):
    """Append spheres to the scene; returns their ids as an int array."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    ids = O.bodies.append([utils.sphere(tuple(c), float(r), material=material)
                           for c, r in zip(centres, radii)])
    return np.asarray(ids, dtype=int)


def packing_fraction(radii, volume):
    return float(np.sum(4.0 / 3.0 * np.pi * np.asarray(radii) ** 3) / volume)
