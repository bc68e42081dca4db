"""Uniaxial compression and tension tests of a CPM packing (the fit of the CPM
micro-parameters to them: yade_side.fit).

The test (after YADE's examples/concrete/uniax.py): the spheres within 1.2 R of both ends of a
box-shaped packing are driven along x at opposite constant speeds by a UniaxialStrainer (ends
free laterally), the others start with the matching linear velocity field. Quasi-static loading
uses Cundall's non-viscous damping (NewtonIntegrator.damping, forces only); the strain rate is low
enough that E and fc no longer depend on it (docs/calibration.md).
- stress = (force on the + end + force on the − end) / 2 / nominal section of the box;
- axial strain between the loaded ends = change of the distance between the mean centres of the
  two end groups over its initial value (the end spheres move rigidly along x);
- ν from the sphere displacements of the middle third of the specimen: least-squares slopes of
  u_y(y), u_z(z) and u_x(x) give the lateral and axial strains there;
- E from the middle third's axial strain (an extensometer) and ν, by least-squares lines over
  the initial part, |σ| from 10 % to 40 % of the peak (E_ends: with the strain between the ends);
- fc, ft are the peak stresses.
"""
import math
import time
from dataclasses import dataclass

import numpy as np

from yade_side import import_yade
from yade_side.bulk import BodySet
from yade_side.material import cpm_material
from yade_side.packing import add_spheres, dense_box_packing, packing_fraction, sphere_arrays
from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

END_DEPTH = 1.2          # end groups: centres within this × R of the extreme centres
ELASTIC_WINDOW = (0.1, 0.4)   # fractions of the peak |σ| over which E and ν are fitted


@dataclass
class Loading:
    strain_rate: float = 0.05     # 1/s, compression: quasi-static for a 0.56 m long specimen
    tension_rate: float = 0.005   # 1/s: ft/E is ~10 × smaller than fc/E, so is the rate
    damping: float = 0.4          # NewtonIntegrator's non-viscous damping (uniax.py's)
    dt_safety: float = 0.8
    stop_ratio: float = 0.7       # stop once |σ| falls below this × the peak after it
    max_strain: float = 5e-3      # or once |ε| exceeds this
    sample_strain: float = 1e-5   # compression strain between samples (same steps in tension)
    shear_release: float = 0.0    # s: the slab's release of cracked links' shear (0: never)

    def __post_init__(self):
        for name in ("strain_rate", "tension_rate", "dt_safety", "max_strain", "sample_strain"):
            if not getattr(self, name) > 0:
                raise ValueError(f"loading {name} must be > 0, got {getattr(self, name)!r}")
        if not 0 <= self.damping < 1:
            raise ValueError(f"loading damping must be in [0, 1), got {self.damping!r}")
        if not self.dt_safety <= 1:
            raise ValueError(f"loading dt_safety must be <= 1 (× the critical step), got "
                             f"{self.dt_safety!r}")
        if not self.shear_release >= 0:
            raise ValueError(f"loading shear_release must be >= 0 s, got {self.shear_release!r}")
        if not 0 < self.stop_ratio < 1:
            raise ValueError(f"loading stop_ratio must be in (0, 1), got {self.stop_ratio!r}")


@dataclass
class Sample:
    """Spheres (centres, radii) filling the box [0, size]; loaded along x."""
    centres: np.ndarray
    radii: np.ndarray
    size: tuple

    @property
    def section(self):
        return self.size[1] * self.size[2]

    @property
    def fraction(self):
        return packing_fraction(self.radii, float(np.prod(self.size)))


def check_specimen(radius, size):
    """Validate a sphere radius and specimen size (m); return the size as a tuple of floats."""
    size = tuple(float(s) for s in size)
    if len(size) != 3 or not all(s > 0 for s in size):
        raise ValueError(f"specimen size must be 3 positive lengths, got {size!r}")
    if not radius > 0:
        raise ValueError(f"sphere radius must be > 0, got {radius!r}")
    if min(size) < 8 * radius:
        raise ValueError(f"specimen {size} is less than 4 sphere diameters ({2 * radius!r} m) "
                         f"across on some axis")
    return size


def packed_sample(radius, size, seed=1):
    """A piece of slab: spheres of `radius` whose centres lie in [0, size], cut from a random
    dense packing (memoized) that is clipped at z = 0 and z = size[2] only, as the slab's packing
    is at its faces. Cut by centres on the four other sides, as the slab's DE zone is cut out of
    the slab's packing, so the nominal section holds the slab's amount of material."""
    size = check_specimen(radius, size)
    margin = 3 * radius
    lo, hi = (-margin, -margin, 0.0), (size[0] + margin, size[1] + margin, size[2])
    centres, radii = sphere_arrays(dense_box_packing(lo, hi, radius, seed=seed))
    keep = np.all((centres[:, :2] >= 0) & (centres[:, :2] < size[:2]), axis=1)
    return Sample(centres[keep], radii[keep], size)


def uniaxial_scene(sample, params, mode, rate, loading=Loading(), material=None):
    """Build the uniaxial test's scene: spheres, CPM engines with a UniaxialStrainer that drives
    the end groups apart ('tension') or together ('compression') at `rate`, cohesive links.
    Returns (ids, strainer, gauge, pair): gauge is the initial distance of the end groups' mean
    centres, pair the strainer's own reference length (its strain × pair is the change of the
    distance between the ends)."""
    if mode not in ("compression", "tension"):
        raise ValueError(f"mode must be 'compression' or 'tension', got {mode!r}")
    yade = import_yade()
    O = yade.Omega()
    reset_scene()
    if material is None:
        mat = cpm_material(params, sample.fraction)
    else:
        mat = O.materials.append(material)
    ids = add_spheres(sample.centres, sample.radii, mat)
    x = sample.centres[:, 0]
    R = float(sample.radii.max())
    neg = np.flatnonzero(x < x.min() + END_DEPTH * R)
    pos = np.flatnonzero(x > x.max() - END_DEPTH * R)
    gauge = x[pos].mean() - x[neg].mean()
    pair = x[pos[0]] - x[neg[0]]     # the strainer's own reference length
    sign = -1.0 if mode == "compression" else 1.0
    _, newton = cpm_engines(dt_safety=loading.dt_safety, shear_release=loading.shear_release)
    newton.damping = loading.damping
    strainer = yade.wrapper.UniaxialStrainer(
        axis=0, asymmetry=0, posIds=ids[pos].tolist(), negIds=ids[neg].tolist(),
        crossSectionArea=sample.section, strainRate=sign * rate * gauge / pair,
        blockDisplacements=False, blockRotations=False, setSpeeds=True, stressUpdateInterval=1)
    # forces and positions of the same step: between the interaction loop and the integrator
    O.engines = O.engines[:-1] + [strainer, O.engines[-1]]
    create_cohesive_links()
    return ids, strainer, gauge, pair


def uniaxial_test(sample, params, mode, loading=Loading(), material=None):
    """One quasi-static uniaxial test, 'compression' or 'tension'. `material` (a CpmMat) replaces
    the one made from `params` (tests). Returns a dict of arrays sampled every `sample_strain`
    (strain between the ends, stress, strain_mid and lateral_mid in the middle third) and the
    measured E, E_ends, ν, peak (signed stress), steps, dt, spheres, seconds."""
    sign, rate = ((-1.0, loading.strain_rate) if mode == "compression"
                  else (1.0, loading.tension_rate))
    ids, strainer, gauge, pair = uniaxial_scene(sample, params, mode, rate, loading, material)
    O = import_yade().Omega()
    x = sample.centres[:, 0]
    every = max(1, round(loading.sample_strain / (loading.strain_rate * O.dt)))

    lo, hi = np.quantile(x, [1 / 3, 2 / 3])
    in_middle = (x > lo) & (x < hi)
    middle, x0 = BodySet(ids[in_middle]), sample.centres[in_middle]
    xm = x0 - x0.mean(axis=0)
    design = [np.column_stack([xm[:, k], np.ones(len(xm))]) for k in range(3)]
    pinv = [np.linalg.pinv(a)[0] for a in design]   # slope of u_k against coordinate k

    strain, stress, strain_mid, lateral_mid = [], [], [], []
    peak, t0 = 0.0, time.perf_counter()
    while True:
        for _ in range(every):   # O.step: O.run(n, True) costs ~40 ms of thread hand-over
            O.step()
        strain.append(strainer.strain * pair / gauge)
        stress.append(strainer.avgStress)
        u = middle.read()[:, :3] - x0
        slopes = [pinv[k] @ u[:, k] for k in range(3)]
        strain_mid.append(slopes[0])
        lateral_mid.append(0.5 * (slopes[1] + slopes[2]))
        s = sign * stress[-1]
        if not math.isfinite(s):
            raise FloatingPointError(f"{mode} test: stress is {stress[-1]} at step {O.iter}")
        peak = max(peak, s)
        if (peak > 0 and s < loading.stop_ratio * peak) or abs(strain[-1]) > loading.max_strain:
            break
    run = {k: np.array(v) for k, v in dict(strain=strain, stress=stress, strain_mid=strain_mid,
                                           lateral_mid=lateral_mid).items()}
    run.update(elastic_constants(run), peak=sign * peak, mode=mode, steps=O.iter, dt=O.dt,
               spheres=len(ids), seconds=time.perf_counter() - t0)
    return run


def elastic_constants(run, window=ELASTIC_WINDOW):
    """Least-squares slopes over |σ| in window × peak |σ| (before the peak): E = dσ/dε with the
    middle third's axial strain (an extensometer, free of the end zones), E_ends with the strain
    between the loaded ends, ν = − dε_lateral/dε_axial in the middle third."""
    s = np.abs(run["stress"])
    before = np.arange(len(s)) <= np.argmax(s)
    sel = before & (s >= window[0] * s.max()) & (s <= window[1] * s.max())
    if sel.sum() < 3:
        raise ValueError(f"only {sel.sum()} samples in the elastic window: lower the strain rate "
                         f"or sample_strain")
    slope = lambda x, y: float(np.polyfit(x[sel], y[sel], 1)[0])
    return dict(E=slope(run["strain_mid"], run["stress"]),
                E_ends=slope(run["strain"], run["stress"]),
                nu=-slope(run["strain_mid"], run["lateral_mid"]))


def summary(compression, tension):
    """The macroscopic values of a compression and a tension (or separation) test."""
    return dict(E=compression["E"], nu=compression["nu"], fc=-compression["peak"],
                ft=tension["peak"], E_tension=tension.get("E"), E_ends=compression["E_ends"],
                fracture_energy=tension.get("fracture_energy"))
