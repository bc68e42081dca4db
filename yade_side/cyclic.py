"""A tension-compression cycle of a CPM specimen: a crack opened in tension, pushed shut in
compression, opened again.

The separation test's specimen and notches (yade_side.fracture): the end groups are driven
apart, then together, then apart, leg by leg, to the target strains between the ends; at each
target the strainer's rate changes sign, and the free spheres' axial velocities are set to the
new leg's linear field, as at the start of a test (no wave from the ends' turn). A CPM
link that cracked in tension is as stiff as before in compression (`sigmaN = (1 − (epsN > 0 ?
omega : 0)) E epsN`, YADE's ConcretePM.cpp): the FE law's crack closure is judged against
this curve (cases/slab/twin.py).
"""
import math
import time

import numpy as np

from yade_side import import_yade
from yade_side.bulk import BodySet
from yade_side.calibration import Loading, uniaxial_scene
from yade_side.fracture import NOTCH, notch_links


def cyclic_test(sample, params, targets, rate, loading=Loading(), notch=None, material=None):
    """Drive the notched specimen (`notch` m deep, default NOTCH × the width) through the
    strains `targets` (between the ends, in turn, each on the other side of the one before) at
    `rate` (1/s); `material` (a CpmMat) replaces the one made from `params` (tests). Returns a
    dict: strain, stress (sampled every loading.sample_strain / 10 of strain), targets, steps,
    dt, spheres, seconds."""
    if not rate > 0:
        raise ValueError(f"cyclic test: rate must be > 0, got {rate!r}")
    O = import_yade().Omega()
    ids, strainer, gauge, pair = uniaxial_scene(sample, params, "tension", rate, loading,
                                                material)
    notch_links(sample, NOTCH * sample.size[1] if notch is None else notch)
    ends = [BodySet(strainer.negIds), BodySet(strainer.posIds)]
    held = set(strainer.negIds) | set(strainer.posIds)
    free = BodySet([i for i in ids.tolist() if i not in held])
    every = max(1, round(loading.sample_strain / 10 / (rate * O.dt)))
    current = lambda: strainer.strain * pair / gauge
    strain, stress, t0 = [current()], [strainer.avgStress], time.perf_counter()
    for k, target in enumerate(targets):
        direction = math.copysign(1.0, target - strain[-1])
        strainer.strainRate = direction * rate * gauge / pair
        if k:
            lo, hi = (e.read()[:, 0].mean() for e in ends)
            free.read()
            velocity = free.vel.copy()       # the ends move at ± rate × gauge / 2
            velocity[:, 0] = direction * rate * gauge * (free.pos[:, 0] - 0.5 * (lo + hi)) / (
                hi - lo)
            free.set_velocity(velocity)
        while (strain[-1] - target) * direction < 0:
            for _ in range(every):
                O.step()
            strain.append(current())
            stress.append(strainer.avgStress)
            if not math.isfinite(stress[-1]):
                raise FloatingPointError(f"cyclic test: stress is {stress[-1]} at step {O.iter}")
    return dict(strain=np.array(strain), stress=np.array(stress), targets=list(targets),
                steps=O.iter, dt=O.dt, spheres=len(ids), seconds=time.perf_counter() - t0)
