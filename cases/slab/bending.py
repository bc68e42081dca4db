"""The FE modulus that bends like the DE slab: `python3 -m cases.slab.bending --scale small`.

A strip of the slab's own packing (0.3 m wide along y, the whole span and thickness) is loaded
quasi-statically in 3-point bending: supports as in the full model (spheres within 2 R of the
x = 0 and x = 2.5 faces held in z), a force P spread over the top spheres of a 0.3 m patch at
mid-span, links kept undamaged (CpmPhys.neverDamage), Cundall damping until the mid-span
deflection settles. The same strip in FE on the scale's grid (held in z on its end faces, as
the coupled model is; the same point forces through the coupling operator k) gives the
deflection of a 31 GPa continuum; the FE is linear, so E_eff = 31 GPa × w_FE / w_DE is the FE
modulus that bends like the spheres
(cases/slab/scales.py SCALES, docs/slab.md). With `--plate`, the whole slab is loaded on the
impactor's 0.3 m square patch and E_eff is read at each bottom patch of the quantities of
interest (x = 0.75, 1.25, 1.75 m): the modulus the slab itself shows, free sides and all.
Each is also given with the FE held on the full model's support line instead (the mean
distance of its held spheres' centres from their end face, 1.4-1.6 R): what the supports'
mismatch puts into E_eff (`E_eff_supports_on_line_Pa`).

The same strip is also loaded to failure, in spheres and in the FE damage law
(`bending_to_failure_de`, `bending_to_failure_fe`: the FE twin, cases/slab/twin.py): the patch
is pushed down at a constant speed (its spheres' z, or its top nodes' z, driven), links and
cells damage, and the force on the patch is recorded against its travel.
"""
import json
from dataclasses import replace

import numpy as np

from cases import slab
from cases.slab.packings import support_line, supported
from cases.slab.quantities import CENTRE, patch_points
from common.arguments import Parser

CENTRE_X = float(CENTRE.split("_x")[1])

STRIP = 0.3          # m, strip width (y)
PATCH = 0.3          # m, loaded patch at mid-span (x; and y on the plate: the impactor's side)
REFERENCE_E = 31e9   # Pa, FE modulus of the reference solve
PLATE_GAUGES = (0.75, 1.25, 1.75)      # m, x of the bottom patches read on the plate
BEND_SPEED = 0.02    # m/s, the strip to failure: its patch's speed (12 periods of the strip's
                     # first mode to 4 mm)
BEND_END = 6e-3      # m, its travel: the small strip's force falls to ~40 % of its peak


def de_deflection(spec, load, tol=2e-4, chunk=500, max_chunks=60):
    """Mid-span, mid-thickness mean z deflection of the DE strip and its sphere count."""
    from yade_side.bulk import BodySet
    packs = slab.make_packings(spec)
    c, r = _strip(packs.slab_centres, packs.slab_radii)
    ids = _loaded(spec, packs, c, r, _top(c, r), load)
    return settled_deflection(BodySet(ids[_gauge(c)]), tol, chunk, max_chunks), len(ids)


def plate_deflections(spec, load, tol=2e-4, chunk=500, max_chunks=80):
    """The whole slab under the impactor's patch (a 0.3 m square of top spheres at the
    centre), quasi-statically: the mean z deflection of each bottom patch of the quantities
    of interest at PLATE_GAUGES, in spheres and in FE (REFERENCE_E, the scale's grid, the same
    point forces; {where the FE is held: its deflections}, _fe_boxes), and the sphere
    count."""
    from yade_side.bulk import BodySet
    packs = slab.make_packings(spec)
    c, r = packs.slab_centres, packs.slab_radii
    centre = 0.5 * np.array(slab.SLAB[:2])
    top = (np.abs(c[:, :2] - centre) < 0.5 * PATCH).all(axis=1) & (c[:, 2] > slab.SLAB[2] - 2 * r)
    patches = patch_points(c, spec.radius)
    gauges = [patches[x] for x in PLATE_GAUGES]
    w_fe = {where: [static_point_deflection(fe, c[top], load, c[g]) for g in gauges]
            for where, fe in _fe_boxes(spec, 0.0, slab.SLAB[1], c, r).items()}
    ids = _loaded(spec, packs, c, r, top, load)
    sets = [BodySet(ids[g]) for g in gauges]          # their displacements from here
    settled_deflection(sets[PLATE_GAUGES.index(CENTRE_X)], tol, chunk, max_chunks)
    w_de = []
    for s in sets:
        s.read()
        w_de.append(float(s.displacement()[:, 2].mean()))
    return w_de, w_fe, len(ids)


def _loaded(spec, packs, c, r, top, load):
    """The scene of the spheres c, r of the scale's concrete, links that never damage,
    Cundall damping, held in z within 2 R of the supported faces, the spheres `top` pushed
    down by `load` (N) in all; their ids."""
    from yade_side import import_yade
    from yade_side.material import cpm_material
    from yade_side.packing import add_spheres
    from yade_side.scene import block_dofs, cpm_engines, create_cohesive_links, reset_scene
    O = import_yade().Omega()
    reset_scene()
    ids = add_spheres(c, r, cpm_material(slab.concrete(spec), packs.slab_fraction))
    _, newton = cpm_engines(dt_safety=0.8)
    create_cohesive_links()
    for i in O.interactions:
        i.phys.neverDamage = True
    newton.damping = 0.5
    block_dofs(ids[supported(c, r)], "z")
    for i in ids[top]:
        O.forces.setPermF(int(i), (0, 0, -load / top.sum()))
    return ids


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
    raise RuntimeError(f"DE deflection did not settle within {max_chunks * chunk} steps")


def fe_deflection(spec, load, where="faces"):
    """The same strip, loads and gauge in FE (REFERENCE_E) on the scale's grid, solved
    statically, held in z `where` (_fe_boxes)."""
    y0 = 0.5 * (slab.SLAB[1] - STRIP)
    packs = slab.make_packings(spec)
    c, r = _strip(packs.slab_centres, packs.slab_radii)
    fe = _fe_boxes(spec, y0, y0 + STRIP, c, r, (where,))[where]
    return static_point_deflection(fe, c[_top(c, r)], load, c[_gauge(c)])


SUPPORTS = ("faces", "line")


def _fe_boxes(spec, y0, y1, c, r, supports=SUPPORTS):
    """{where: the elastic FE slab (REFERENCE_E) between y0 and y1 on the scale's grid, held
    in z there}: "faces", its end faces (the coupled model's supports); "line", the planes at
    the full model's support line from each end (packings.support_line of the spheres c, r),
    the grid's planes and those two."""
    from fenicsx_side.mesh import tensor_box_with_hole
    from fenicsx_side.model import ElasticModel
    grid = slab.slab_grid(spec)
    length = slab.SLAB[0]
    ys = np.linspace(y0, y1, max(1, round((y1 - y0) / grid.h)) + 1)
    zs = np.linspace(0.0, slab.SLAB[2], grid.n[2] + 1)
    out = {}
    for where in supports:
        s = 0.0 if where == "faces" else support_line(c, r)
        xs = np.unique(np.r_[np.linspace(0.0, length, grid.n[0] + 1), s, length - s])
        fe = ElasticModel(tensor_box_with_hole(xs, ys, zs), REFERENCE_E, spec.poisson,
                          spec.density)
        x = fe.nodes[:, 0]
        fe.hold((np.abs(x - s) < 1e-9) | (np.abs(x - (length - s)) < 1e-9), (2,))
        out[where] = fe
    return out


def static_point_deflection(fe, points, load, gauges):
    """Mean z deflection at `gauges` of the FE model `fe`, solved statically, under a force
    `load` (N, along −z) shared equally by `points` (through the coupling operator k)."""
    k, _ = fe.point_operators(points)
    f = np.zeros((len(points), 3))
    f[:, 2] = -load / len(points)
    u = np.zeros(fe.ndof)
    free = np.flatnonzero(~fe.fixed)
    u[free] = _static_solve(fe.K, free, (k.T @ f.ravel())[free])
    g, _ = fe.point_operators(gauges)
    return float((g @ u).reshape(-1, 3)[:, 2].mean())


def bending_to_failure_de(spec, speed, end, samples=400, loading=None):
    """The DE strip (the scale's CPM set, calibration's step and damping) with its patch pushed
    down at `speed` (m/s) to a travel `end` (m). Returns (travel, force) arrays (m, N; the
    force the strip puts back on the patch, positive upwards), the sphere count and seconds."""
    import time
    from yade_side import import_yade
    from yade_side.calibration import Loading
    from yade_side.material import cpm_material
    from yade_side.packing import add_spheres
    from yade_side.scene import block_dofs, cpm_engines, create_cohesive_links, reset_scene
    loading = Loading() if loading is None else loading
    O = import_yade().Omega()
    packs = slab.make_packings(spec)
    c, r = _strip(packs.slab_centres, packs.slab_radii)
    reset_scene()
    ids = add_spheres(c, r, cpm_material(slab.concrete(spec), packs.slab_fraction))
    _, newton = cpm_engines(dt_safety=loading.dt_safety, shear_release=loading.shear_release)
    create_cohesive_links()
    newton.damping = loading.damping
    block_dofs(ids[supported(c, r)], "z")
    patch = [int(i) for i in ids[_top(c, r)]]
    block_dofs(patch, "z")
    for i in patch:
        O.bodies[i].state.vel = (0, 0, -speed)
    steps = int(np.ceil(end / speed / O.dt))
    every = max(1, steps // samples)
    travel, force, t0 = [0.0], [0.0], time.perf_counter()
    for k in range(1, steps + 1):
        O.step()
        if k % every == 0 or k == steps:
            travel.append(speed * k * O.dt)
            force.append(sum(O.forces.f(i)[2] for i in patch))
            if not np.isfinite(force[-1]):
                raise FloatingPointError(f"bending strip: force is {force[-1]} at step {k}")
    return np.array(travel), np.array(force), len(ids), time.perf_counter() - t0


def bending_to_failure_fe(spec, law, speed, end, samples=400):
    """The FE strip (the FE damage law `law` on the scale's grid, the supports of
    `fe_deflection`) with the top nodes of the patch pushed down at `speed` (m/s) to a travel
    `end` (m), explicit steps at half the critical one. Returns (travel, force, the energy the
    damage dissipated, the cells along x, y, z): the force the strip puts back on the patch,
    positive upwards."""
    m, driven, n = _fe_strip(spec, law)
    dt = 0.5 * m.critical_dt()
    steps = int(np.ceil(end / speed / dt))
    every = max(1, steps // samples)
    # every node starts on the elastic strip's static deflection shape, scaled to the patch's
    # speed: no ringing from the start (the FE has no damping)
    shape = _static_shape(m, driven)
    m.u = np.where(m.fixed, 0.0, speed * dt * shape)   # one step ahead, as the patch:
    m.v = np.where(m.fixed, 0.0, speed * shape)
    m.correct(driven, np.full(driven.size, -speed * dt), dt)
    travel, force = [0.0], [0.0]
    for k in range(1, steps + 1):
        m.predict(dt)
        if k % every == 0 or k == steps:
            travel.append(-m.u[driven].mean())
            force.append(-m.internal_force()[driven].sum())
    return np.array(travel), np.array(force), m.dissipated, n


def strength_for_peak(spec, peak, speed, end, tol=0.005):
    """The FE damage law's tensile strength at which the FE strip bent to failure
    (bending_to_failure_fe at `speed` to a travel `end`) peaks at the force `peak` (N): e.g.
    the spheres' strip's, from the twin (cases/slab/twin.py). Returns (strength (Pa), the
    [strength, peak] pairs tried)."""
    from fenicsx_side.damage_law import ConcreteDamage
    law = spec.damage_law()

    def fe_peak(strength):
        curve = bending_to_failure_fe(spec, ConcreteDamage(**dict(law, tensile_strength=strength)),
                                      speed, end)[1]
        return float(curve.max())
    return increasing_root(fe_peak, law["tensile_strength"], peak, tol)


def increasing_root(f, x0, target, tol, step=0.1, max_iter=12):
    """x with f(x) within tol × target of `target`, f increasing: secant steps from x0 and
    (1 + step) x0, halving the bracket instead where a step would leave it. Returns (x,
    [[x, f(x)] tried])."""
    if not target > 0:
        raise ValueError(f"the peak to match must be > 0, got {target!r}")
    tried = []

    def probe(x):
        tried.append([x, f(x)])
        return tried[-1][1]
    a, fa = x0, probe(x0)
    if abs(fa - target) <= tol * target:
        return a, tried
    b, fb = (1 + step) * x0, probe((1 + step) * x0)
    for _ in range(max_iter):
        if abs(fb - target) <= tol * target:
            return b, tried
        if not (fb - fa) * (b - a) > 0:
            raise RuntimeError(f"the peak does not grow with the strength: tried {tried}")
        x = b + (target - fb) * (b - a) / (fb - fa)
        lo = max((p for p, v in tried if v < target), default=None)
        hi = min((p for p, v in tried if v > target), default=None)
        if lo is not None and hi is not None and not lo < x < hi:
            x = 0.5 * (lo + hi)
        a, fa, b, fb = b, fb, x, probe(x)
    raise RuntimeError(f"no strength within {tol:.1%} of the peak {target:.4g} in {max_iter} "
                       f"steps: tried {tried}")


def higher_order_share(spec, law):
    """The share of the FE strip's bending energy (its static deflection under the patch) that
    its cells' higher-order stiffness carries (K_c less the one-point part: what the damage
    law's split does not see), and the share left with every cell at D = 1."""
    from fenicsx_side.damage_law import contract
    m, driven, _ = _fe_strip(spec, law)
    m.u = np.where(m.fixed, 0.0, _static_shape(m, driven))
    m.correct(driven, np.full(driven.size, -1.0), 1.0)
    total = float(m.u @ (m.K @ m.u))
    eps = m.cell_strain()
    one_point = float(m.cell_volume @ contract(law.effective_stress(eps), eps))
    m.damage_t[:] = m.damage_c[:] = m.damage[:] = 1.0
    return 1 - one_point / total, float(m.u @ m.internal_force()) / total


def _fe_strip(spec, law):
    """The FE strip with the damage law `law` on the scale's grid, held in z at both ends and
    at its patch's top nodes. Returns (model, the patch's z dofs, cells along x, y, z)."""
    from fenicsx_side.damaged import DamageModel
    from fenicsx_side.mesh import box_mesh
    from fenicsx_side.model import face
    grid = slab.slab_grid(spec)
    y0 = 0.5 * (slab.SLAB[1] - STRIP)
    n = [grid.n[0], max(1, round(STRIP / grid.h)), grid.n[2]]
    top = lambda x: (np.abs(x[0] - 0.5 * slab.SLAB[0]) <= 0.5 * PATCH + 1e-8) & (
        np.abs(x[2] - slab.SLAB[2]) <= 1e-8)
    m = DamageModel(box_mesh((0, y0, 0), (slab.SLAB[0], y0 + STRIP, slab.SLAB[2]), n), law,
                    spec.density, [(face(0, 0.0), (2,)), (face(0, slab.SLAB[0]), (2,)),
                                   (top, (2,))])
    z = np.arange(m.ndof) % 3 == 2
    return m, np.flatnonzero(m.fixed & z & np.repeat(top(m.nodes.T), 3)), tuple(n)


def _static_shape(m, driven):
    """The static deflection of model m with its `driven` dofs at −1 (the others held at 0)."""
    shape = np.zeros(m.ndof)
    shape[driven] = -1.0
    free = np.flatnonzero(~m.fixed)
    shape[free] = _static_solve(m.K, free, -(m.K[:, driven] @ shape[driven])[free])
    return shape


def _static_solve(K, free, rhs, refinements=3):
    """K[free, free] u = rhs, rhs free of the in-plane rigid motions the supports leave free
    (K's own null space there). Solved with a spring 1e-9 × the mean stiffness on every dof,
    which removes them, then refined on the residual of K itself: each pass takes the spring's
    error down by 1e-9 × the mean stiffness over the strip's softest bending stiffness."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu
    K = K[free][:, free].tocsc()
    lu = splu((K + 1e-9 * K.diagonal().mean() * sp.identity(len(free))).tocsc())
    u = lu.solve(rhs)
    for _ in range(refinements):
        u += lu.solve(rhs - K @ u)
    return u


def _strip(c, r):
    keep = np.abs(c[:, 1] - 0.5 * slab.SLAB[1]) < 0.5 * STRIP
    return c[keep], r[keep]


def _top(c, r):
    return (np.abs(c[:, 0] - 0.5 * slab.SLAB[0]) < 0.5 * PATCH) & (c[:, 2] > slab.SLAB[2] - 2 * r)


def _gauge(c):
    return (np.abs(c[:, 0] - 0.5 * slab.SLAB[0]) < 0.2) & (np.abs(c[:, 2] - 0.5 * slab.SLAB[2]) < 0.06)


def main(argv=None):
    p = Parser(prog="python3 -m cases.slab.bending", description=__doc__.splitlines()[0])
    p.add_argument("--scale", choices=tuple(slab.SCALES), default="small")
    p.add_argument("--load", type=float, default=2e4, help="total force P (N), elastic range")
    p.add_argument("--fe-strength-for-peak", type=float, default=None, metavar="N",
                   help="only the FE damage law's tensile strength at which the FE strip bent "
                        "to failure (the twin's test) peaks at N newtons, e.g. the spheres' "
                        "strip's peak that `calibrate --fe-twin` prints")
    p.add_argument("--fe-ratio", type=float, default=None,
                   help="the FE grid's in-plane cell size / sphere diameter (default: the "
                        "slab's): E_eff is the modulus of that grid")
    p.add_argument("--plate", action="store_true",
                   help="the whole slab under the impactor's 0.3 m patch instead of the strip: "
                        "E_eff at each bottom patch of the quantities of interest")
    p.add_argument("--higher-order", action="store_true",
                   help="only the share of the FE strip's bending energy in its cells' "
                        "higher-order stiffness, and what every cell at D = 1 leaves (FE damage "
                        "law of the scale; Gf 443.5 J/m² where the scale has none)")
    a = p.parse_args(argv)
    if a.higher_order:
        from cases.slab.scales import concrete_set
        from fenicsx_side.damage_law import ConcreteDamage
        gf = None if concrete_set(a.scale, "plain").fracture_energy else 443.5
        spec = slab.SlabSpec(scale=a.scale, fe_material="damage", fracture_energy=gf)
        share, left = higher_order_share(spec, ConcreteDamage(**spec.damage_law()))
        print(json.dumps({"scale": a.scale, "higher_order_share": share,
                          "left_at_full_damage": left}))
        return
    try:
        spec = slab.SlabSpec(scale=a.scale, **({} if a.fe_ratio is None
                                               else {"fe_ratio": a.fe_ratio}))
    except ValueError as e:
        p.error(str(e))
    if a.fe_strength_for_peak is not None:
        if not a.fe_strength_for_peak > 0:
            p.error(f"--fe-strength-for-peak must be > 0 newtons, got {a.fe_strength_for_peak!r}")
        spec = replace(spec, fe_material="damage")
        strength, tried = strength_for_peak(spec, a.fe_strength_for_peak, BEND_SPEED, BEND_END)
        print(json.dumps({"scale": a.scale, "peak_N": a.fe_strength_for_peak,
                          "tensile_strength_Pa": strength,
                          "over_the_spheres_ft": strength / spec.tensile_strength,
                          "tried": tried}))
        return
    packs = slab.make_packings(spec)
    if a.plate:
        line = support_line(packs.slab_centres, packs.slab_radii)
        w_de, w_fe, spheres = plate_deflections(spec, a.load)
        print(json.dumps({"scale": a.scale, "radius": spec.radius, "spheres": spheres,
                          "load_N": a.load, "x_m": PLATE_GAUGES, "deflection_de_m": w_de,
                          "deflection_fe_31GPa_m": w_fe["faces"],
                          "E_eff_Pa": [REFERENCE_E * f / d for f, d in zip(w_fe["faces"], w_de)],
                          "support_line_m": line,
                          "E_eff_supports_on_line_Pa": [REFERENCE_E * f / d for f, d
                                                        in zip(w_fe["line"], w_de)]}))
        return
    line = support_line(*_strip(packs.slab_centres, packs.slab_radii))
    w_fe = {where: fe_deflection(spec, a.load, where) for where in SUPPORTS}
    w_de, spheres = de_deflection(spec, a.load)
    print(json.dumps({"scale": a.scale, "radius": spec.radius, "spheres": spheres, "load_N": a.load,
                      "deflection_de_m": w_de, "deflection_fe_31GPa_m": w_fe["faces"],
                      "E_eff_Pa": REFERENCE_E * w_fe["faces"] / w_de, "support_line_m": line,
                      "E_eff_supports_on_line_Pa": REFERENCE_E * w_fe["line"] / w_de}))


if __name__ == "__main__":
    main()
