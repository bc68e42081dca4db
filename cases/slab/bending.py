"""The FE modulus that bends like the DE slab: `python3 -m cases.slab.bending --scale small`.

A strip of the slab's own packing (0.3 m wide along y, the whole span and thickness) is loaded
quasi-statically in 3-point bending: supports as in the full model (spheres within 2 R of the
x = 0 and x = 2.5 faces held in z), a force P spread over the top spheres of a 0.3 m patch at
mid-span, links kept undamaged (CpmPhys.neverDamage), Cundall damping until the mid-span
deflection settles. The same strip in FE on the scale's grid (same supports, the same point
forces through the coupling operator k) gives the deflection of a 31 GPa continuum; the FE is
linear, so E_eff = 31 GPa × w_FE / w_DE is the FE modulus that bends like the spheres
(cases/slab/scales.py SCALES, docs/slab.md).
"""
import argparse
import json

import numpy as np

from cases import slab

STRIP = 0.3          # m, strip width (y)
PATCH = 0.3          # m, loaded patch at mid-span (x)
REFERENCE_E = 31e9   # Pa, FE modulus of the reference solve


def de_deflection(spec, load, tol=2e-4, chunk=500, max_chunks=60):
    """Mid-span, mid-thickness mean z deflection of the DE strip and its sphere count."""
    from yade_side import import_yade
    from yade_side.bulk import BodySet
    from yade_side.material import cpm_material
    from yade_side.packing import add_spheres
    from yade_side.scene import block_dofs, cpm_engines, create_cohesive_links, reset_scene
    O = import_yade().Omega()
    packs = slab.make_packings(spec)
    c, r = _strip(packs.slab_centres, packs.slab_radii)
    reset_scene()
    ids = add_spheres(c, r, cpm_material(slab.concrete(spec), packs.slab_fraction))
    _, newton = cpm_engines(dt_safety=0.8)
    create_cohesive_links()
    for i in O.interactions:
        i.phys.neverDamage = True
    newton.damping = 0.5
    block_dofs(ids[(c[:, 0] < 2 * r) | (c[:, 0] > slab.SLAB[0] - 2 * r)], "z")
    top = _top(c, r)
    for i in ids[top]:
        O.forces.setPermF(int(i), (0, 0, -load / top.sum()))
    return settled_deflection(BodySet(ids[_gauge(c)]), tol, chunk, max_chunks), len(ids)


def settled_deflection(gauge, tol=2e-4, chunk=500, max_chunks=60):
    """The mean z displacement of the spheres `gauge` once it changes by less than tol
    (relative) over `chunk` steps of the damped quasi-static run."""
    from yade_side import import_yade
    O = import_yade().Omega()
    last = None
    for _ in range(max_chunks):
        O.run(chunk, True)
        gauge.read()
        w = float(gauge.displacement()[:, 2].mean())
        if last is not None and abs(w - last) < tol * abs(w):
            return w
        last = w
    raise RuntimeError(f"DE strip deflection did not settle within {max_chunks * chunk} steps")


def fe_deflection(spec, load):
    """The same strip, loads and gauge in FE (REFERENCE_E) on the scale's grid, solved statically."""
    from fenicsx_side.mesh import box_mesh
    from fenicsx_side.model import ElasticModel, face
    grid = slab.slab_grid(spec)
    y0 = 0.5 * (slab.SLAB[1] - STRIP)
    n = [grid.n[0], max(1, round(STRIP / grid.h)), grid.n[2]]
    fe = ElasticModel(box_mesh((0, y0, 0), (slab.SLAB[0], y0 + STRIP, slab.SLAB[2]), n),
                      REFERENCE_E, spec.poisson, spec.density,
                      [(face(0, 0.0), (2,)), (face(0, slab.SLAB[0]), (2,))])
    packs = slab.make_packings(spec)
    c, r = _strip(packs.slab_centres, packs.slab_radii)
    return static_point_deflection(fe, c[_top(c, r)], load, c[_gauge(c)])


def static_point_deflection(fe, points, load, gauges):
    """Mean z deflection at `gauges` of the FE model `fe`, solved statically, under a force
    `load` (N, along −z) shared equally by `points` (through the coupling operator k)."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve
    k, _ = fe.point_operators(points)
    f = np.zeros((len(points), 3))
    f[:, 2] = -load / len(points)
    free = np.flatnonzero(~fe.fixed)
    K = fe.K[free][:, free]
    # the supports leave the in-plane rigid motions free: a spring 1e-9 × the mean stiffness
    # removes them without touching the bending deflection
    K = (K + 1e-9 * K.diagonal().mean() * sp.identity(len(free))).tocsc()
    u = np.zeros(fe.ndof)
    u[free] = spsolve(K, (k.T @ f.ravel())[free])
    g, _ = fe.point_operators(gauges)
    return float((g @ u).reshape(-1, 3)[:, 2].mean())


def _strip(c, r):
    keep = np.abs(c[:, 1] - 0.5 * slab.SLAB[1]) < 0.5 * STRIP
    return c[keep], r[keep]


def _top(c, r):
    return (np.abs(c[:, 0] - 0.5 * slab.SLAB[0]) < 0.5 * PATCH) & (c[:, 2] > slab.SLAB[2] - 2 * r)


def _gauge(c):
    return (np.abs(c[:, 0] - 0.5 * slab.SLAB[0]) < 0.2) & (np.abs(c[:, 2] - 0.5 * slab.SLAB[2]) < 0.06)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scale", choices=tuple(slab.SCALES), default="small")
    p.add_argument("--load", type=float, default=2e4, help="total force P (N), elastic range")
    a = p.parse_args(argv)
    spec = slab.SlabSpec(scale=a.scale)
    w_fe = fe_deflection(spec, a.load)
    w_de, spheres = de_deflection(spec, a.load)
    print(json.dumps({"scale": a.scale, "radius": spec.radius, "spheres": spheres, "load_N": a.load,
                      "deflection_de_m": w_de, "deflection_fe_31GPa_m": w_fe,
                      "E_eff_Pa": REFERENCE_E * w_fe / w_de}))


if __name__ == "__main__":
    main()
