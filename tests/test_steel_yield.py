"""Steel that yields (cases.reinforcement.Bars.steel_step): EN 1992-1-1's bilinear curve, E up
to fy then the hardening slope H, in the DE chains (yade_side.bars: YADE's own link forces)
and the FE trusses (fenicsx_side.bars: the model's internal force and energy), along a strain
path that loads past fy, unloads, yields in compression and reloads, against the curve's
closed form: past yield a monotonic segment follows the tangent modulus E H / (E + H)."""
import math

import numpy as np
import pytest

from cases.reinforcement import Bars
from fenicsx_side.bars import EmbeddedBars
from fenicsx_side.mesh import box_mesh
from fenicsx_side.model import ElasticModel
from yade_side import import_yade
from yade_side.bars import Bond, SteelChains
from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

yade = import_yade()
E_S, FY, D, R = 200e9, 500e6, 0.012, 0.01
EPS_Y = FY / E_S
PATH = np.array([0.0, 3.0, 1.0, -3.0, 0.0]) * EPS_Y     # corners of the strain path
HARDENING = (0.0, 2e9)
TOL = 1e-9 * FY         # the stresses are differences of strains of order 1e-3: round-off


def bars_along_x(length, hardening, start=(0.0, 0.0, 0.0)):
    start = np.array([start], float)
    return Bars(start, start + (length, 0.0, 0.0), np.array([D]), np.array([E_S]),
                np.array([FY]), np.array([7850.0]), np.array([np.nan]), np.array([0]),
                np.array([hardening]))


def closed_form(strains, H):
    """σ and the plastic work per unit volume at each strain of a path taken in monotonic
    pieces (consecutive strains), from the yield condition |σ| = fy + H α and the tangent
    modulus E H / (E + H) past it: no return mapping."""
    sigma, eps_p, alpha, work = [0.0], 0.0, 0.0, [0.0]
    for a, b in zip(strains[:-1], strains[1:]):
        s = np.sign(b - a)
        onset = eps_p + s * (FY + H * alpha) / E_S     # where this piece starts yielding
        flow = max(0.0, s * (b - onset)) * E_S / (E_S + H)
        work.append(work[-1] + flow * (FY + H * (alpha + 0.5 * flow)))
        eps_p, alpha = eps_p + s * flow, alpha + flow
        sigma.append(E_S * (b - eps_p))
    return np.array(sigma), np.array(work)


def fine_path(pieces):
    """The strain path with `pieces` equal increments per segment."""
    return np.concatenate([[PATH[0]]] + [np.linspace(a, b, pieces + 1)[1:]
                                          for a, b in zip(PATH[:-1], PATH[1:])])


@pytest.mark.parametrize("H", HARDENING)
@pytest.mark.parametrize("pieces", [1, 7, 400])
def test_the_law_is_the_bilinear_curve_whatever_the_step(H, pieces):
    bars = bars_along_x(1.0, H)
    strains = fine_path(pieces)
    plastic, accumulated = np.zeros(1), np.zeros(1)
    sigma, work = [], 0.0
    for eps in strains[1:]:
        s, w = bars.steel_step(np.array([0]), np.array([eps]), plastic, accumulated)
        sigma.append(s[0])
        work += w[0]
    expected, expected_work = closed_form(strains, H)
    assert np.abs(np.array(sigma) - expected[1:]).max() <= TOL
    assert work == pytest.approx(expected_work[-1], rel=1e-12)
    if H == 0:      # yielding over 2, 4 and 1 εy of the path: work fy × 7 εy
        assert work == pytest.approx(7 * FY * EPS_Y, rel=1e-12)


def de_curve(H, steps_per_segment=60):
    """A bar of seven steel spheres driven kinematically along the strain path (the linear
    velocity field of a uniform strain rate): every step, the stress of every link as YADE
    computed it (Fn / A) against the law's state before that step. Returns (strains and
    stresses of the last link along the path, largest YADE-vs-law difference, the chain)."""
    reset_scene()
    O = yade.Omega()
    chain = SteelChains(bars_along_x(6 * 2 * R, H), R, Bond(5e6, 1e11), dt_floor=1e-7)
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    chain.start_plasticity()
    x0 = np.array([O.bodies[i].state.pos[0] for i in chain.ids.tolist()])
    strains, stresses, worst = [], [], 0.0
    law = lambda: E_S * (chain.strain() - chain.steel.plastic)     # at the positions now
    for a, b in zip(PATH[:-1], PATH[1:]):
        rate = (b - a) / (steps_per_segment * O.dt)
        for i, x in zip(chain.ids.tolist(), x0):
            O.bodies[i].state.blockedDOFs = "xyzXYZ"
            O.bodies[i].state.vel = (rate * x, 0.0, 0.0)
        for _ in range(steps_per_segment):
            strains.append(chain.strain()[-1])
            stresses.append(law())
            O.step()                                        # its forces, then the motion
            worst = max(worst, np.abs(chain.steel_stress() - stresses[-1]).max())
            chain.plastic_step()
    strains.append(chain.strain()[-1])
    stresses.append(law())
    return np.array(strains), np.array(stresses)[:, -1], worst, chain


@pytest.mark.parametrize("H", HARDENING)
def test_de_chain_links_follow_the_law_and_dissipate_its_work(H):
    strains, stresses, worst, chain = de_curve(H)
    assert worst <= TOL                    # YADE's own link forces are the law's
    assert np.abs(strains[[0, 60, 120, 180, 240]] - PATH).max() < 1e-12
    expected, work = closed_form(strains, H)
    assert np.abs(stresses - expected).max() <= TOL
    volume = math.pi * D ** 2 / 4 * 6 * 2 * R
    assert chain.steel.work == pytest.approx(work[-1] * volume, rel=1e-9)


def fe_curve(H, steps_per_segment=60):
    """An FE box with a bar along x through it, strained uniformly along x (u = ε x e_x)
    along the path: the bars' part of the model's internal force and of its strain energy,
    against a model of the same box without bars. Returns (strains, the bar's stress from
    the force, largest energy mismatch)."""
    mesh = lambda: box_mesh((0.0, 0.0, 0.0), (0.4, 0.2, 0.2), (4, 2, 2))
    plain = ElasticModel(mesh(), 31e9, 0.2, 2400.0)
    model = ElasticModel(mesh(), 31e9, 0.2, 2400.0)
    bars = bars_along_x(0.3, H, start=(0.05, 0.07, 0.09))
    fe = EmbeddedBars(model, bars, element_length=0.05)
    fe.add_to(model)
    x = model.nodes[:, 0]
    strains, stresses, energy_error = [0.0], [0.0], 0.0
    for eps in fine_path(steps_per_segment)[1:]:
        u = np.zeros_like(model.u)
        u[0::3] = eps * x
        model.u = plain.u = u
        force = model.K @ u
        model._members_force(force)
        bar_force = force - plain.K @ u                 # Pᵀ Bᵀ N, N the elements' forces
        N = np.linalg.lstsq(fe.G.T.toarray(), bar_force, rcond=None)[0]
        strains.append(eps)
        stresses.append(N[0] / fe.area[0])
        elastic = np.sum(0.5 * fe.k * ((fe.G @ u) - fe.steel.plastic * fe.length) ** 2)
        energy_error = max(energy_error, abs(model.strain_energy() - plain.strain_energy() -
                                             elastic) / (0.5 * FY ** 2 / E_S * fe.area.sum()
                                                         * fe.length.sum()))
        assert np.abs(N - N[0]).max() <= TOL * fe.area[0]      # uniform along the bar
    return np.array(strains), np.array(stresses), energy_error, fe


@pytest.mark.parametrize("H", HARDENING)
def test_fe_bars_follow_the_law_in_force_and_energy(H):
    strains, stresses, energy_error, fe = fe_curve(H)
    expected, work = closed_form(strains, H)
    assert np.abs(stresses - expected).max() <= TOL
    assert energy_error < 1e-10
    assert fe.steel.work == pytest.approx(work[-1] * fe.area[0] * fe.length.sum(), rel=1e-9)
    assert set(fe.history()) == {"plastic", "accumulated", "plastic_work"}


def test_the_de_and_fe_bars_give_the_same_curve():
    de_strains, de_stresses, _, _ = de_curve(2e9)
    fe_strains, fe_stresses, _, _ = fe_curve(2e9)
    assert np.abs(de_strains - fe_strains).max() < 1e-12
    assert np.abs(de_stresses - fe_stresses).max() <= TOL
