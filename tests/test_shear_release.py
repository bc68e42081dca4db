"""Shear release of cracked CPM links (yade_side.scene.release_cracked_shear)."""
import math

import pytest

from yade_side import import_yade
from yade_side.scene import (SHEAR_RELEASE_OMEGA, cpm_engines, create_cohesive_links,
                             release_cracked_shear, reset_scene)

yade = import_yade()
O = yade.Omega()
R, E, EPS0 = 0.01, 30e9, 1e-4


def pair(stretch, every=0):
    """Two touching spheres linked, moved kinematically: pulled apart by `stretch` × the
    link length, pushed back to a compressive strain of 5e-4, then sheared by 1e-6 m."""
    reset_scene()
    from yade import utils
    mat = O.materials.append(yade.wrapper.CpmMat(young=E, poisson=0.2, frictionAngle=0.67,
                                                 sigmaT=3e6, epsCrackOnset=EPS0,
                                                 relDuctility=30, density=4000))
    ids = O.bodies.append([utils.sphere((0, 0, 0), R, material=mat),
                           utils.sphere((2 * R, 0, 0), R, material=mat)])
    cpm_engines(dt=1e-6, shear_release=every * 1e-6)
    create_cohesive_links()
    for b in O.bodies:
        b.state.blockedDOFs = "xyzXYZ"
    moving = O.bodies[ids[1]].state
    for velocity, steps in (((0.1, 0, 0), round(stretch * 2 * R / 1e-7)),
                            ((-0.1, 0, 0), round((stretch + 5e-4) * 2 * R / 1e-7)),
                            ((0, 0.01, 0), 100)):
        moving.vel = velocity
        for _ in range(steps):
            O.step()
    return O.interactions[ids[0], ids[1]].phys


def cpm_omega(kappa):
    """CPM's exponential damage law at the largest strain kappa (relDuctility 30)."""
    return 1 - EPS0 / kappa * math.exp(-(kappa - EPS0) / (30 * EPS0))


def test_a_cracked_link_loses_its_shear_and_keeps_its_normal_law():
    # stretched to 10 ε0: ω = 0.926, between the release (0.9) and deletion (0.99) thresholds
    assert SHEAR_RELEASE_OMEGA < cpm_omega(10 * EPS0) < 0.99
    kept = pair(10 * EPS0)
    assert kept.omega == pytest.approx(cpm_omega(10 * EPS0), rel=1e-6)
    # in compression the crack keeps full shear stiffness: 1e-6 m of slip on a 0.02 m link,
    # elastic (far below the friction limit), Fs = G A γ
    assert kept.shearForce.norm() == pytest.approx(0.2 * E * math.pi * R**2 * 1e-6 / (2 * R),
                                                   rel=1e-3)
    released = pair(10 * EPS0, every=1)
    assert released.G == 0 and released.shearForce.norm() == 0
    # the normal law is untouched: the same compressive force as without the release
    assert released.normalForce.norm() == kept.normalForce.norm() > 0


def test_a_link_below_the_threshold_is_left_alone():
    assert cpm_omega(5 * EPS0) < SHEAR_RELEASE_OMEGA
    kept, released = pair(5 * EPS0), pair(5 * EPS0, every=1)
    assert released.G == kept.G == 0.2 * E
    assert released.shearForce.norm() == kept.shearForce.norm() > 0
    assert release_cracked_shear() == 0
    assert release_cracked_shear(omega=0.5) == 1 and O.interactions[0, 1].phys.G == 0
