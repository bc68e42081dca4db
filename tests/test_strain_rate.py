"""Is Debian's CPM law (YADE 2023.02a) rate-dependent? Its CpmMat has the rate parameters of the
full model (dmgTau, dmgRateExp for damage, plTau, plRateExp for shear plasticity), whose
overstress functions the public law never calls (docs/calibration.md)."""
import math

import numpy as np
import pytest

from yade_side import import_yade
from yade_side.scene import cpm_engines, reset_scene

yade = import_yade()
R, E, EPS0, REL_DUCTILITY = 0.01, 30e9, 1e-4, 5.0


def pulled_link(rate, direction, steps, **rate_params):
    """Two touching spheres linked by CPM, the second driven at constant velocity
    rate × 2R × direction (both kinematic): the force history on the first, (steps, 3), and
    the strain along the link axis at each step."""
    reset_scene()
    O = yade.Omega()
    mat = O.materials.append(yade.wrapper.CpmMat(
        young=E, poisson=0.2, frictionAngle=0.5, sigmaT=3e6, epsCrackOnset=EPS0,
        relDuctility=REL_DUCTILITY, density=4000, **rate_params))
    from yade import utils
    a = O.bodies.append(utils.sphere((0, 0, 0), R, material=mat))
    b = O.bodies.append(utils.sphere((2 * R, 0, 0), R, material=mat))
    for i in (a, b):
        O.bodies[i].state.blockedDOFs = "xyzXYZ"
    cpm_engines(dt=1e-7, threshold=1.0)
    O.bodies[b].state.vel = tuple(rate * 2 * R * np.asarray(direction, float))
    forces, strain = [], []
    for _ in range(steps):
        O.step()
        forces.append(tuple(O.forces.f(a)))
        strain.append(O.bodies[b].state.pos[0] / (2 * R) - 1)
    return np.array(forces), np.array(strain)


@pytest.mark.parametrize("direction", [(1, 0, 0), (1, 1, 0)])
def test_rate_parameters_change_nothing(direction):
    """At 50 /s (impact rates), through damage (tension) and shear slip (oblique pull), the
    force history with dmgTau = plTau = 1e-4 s (overstress relaxation times comparable to the
    ~1e-4 s the link takes to crack) is bit-identical to the one without."""
    steps = 4000      # ε = 50 /s × 4e-4 s = 2e-2: far past the break (x* ε0 ≈ 1.2e-3)
    plain, _ = pulled_link(50.0, direction, steps)
    rated, _ = pulled_link(50.0, direction, steps, dmgTau=1e-4, dmgRateExp=1.0, plTau=1e-4,
                           plRateExp=1.0)
    assert np.abs(plain).max() > 0
    assert np.array_equal(plain, rated)


def test_tension_force_is_the_static_law_at_impact_rate():
    """Pulled at 50 /s, the link force is at every step the rate-independent law of its current
    strain: F = π R² E ε (ε < ε0), π R² E ε0 exp(−(κ − ε0)/εf) on the softening branch."""
    forces, strain = pulled_link(50.0, (1, 0, 0), 2000)
    eps = strain - 50.0 * 2 * R * 1e-7 / (2 * R)   # the force of step n is from the positions before it moved
    static = math.pi * R**2 * E * np.where(
        eps < EPS0, eps, EPS0 * np.exp(-(eps - EPS0) / (REL_DUCTILITY * EPS0)))
    assert np.allclose(forces[:, 0], static, rtol=1e-9, atol=1e-9 * static.max())
