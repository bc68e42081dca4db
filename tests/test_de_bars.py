"""Bars in the DE model (yade_side.bars): chains of CPM spheres with the steel's EA, bonded to
the concrete by links of a given bond strength."""
import math

import numpy as np
import pytest

from cases.reinforcement import Bars
from yade_side import import_yade
from yade_side.bars import Bond, SteelChains
from yade_side.packing import add_spheres
from yade_side.scene import block_dofs, cpm_engines, create_cohesive_links, reset_scene

yade = import_yade()
R = 0.01
E_S, D = 200e9, 0.012
A_S = math.pi * D**2 / 4


def one_bar(length, fy=500e6):
    return Bars(np.array([[0.0, 0.0, 0.0]]), np.array([[length, 0.0, 0.0]]), np.array([D]),
                np.array([E_S]), np.array([fy]), np.array([7850.0]), np.array([np.nan]),
                np.array([0]))


def drive(ids, vel):
    """Kinematic spheres: all dofs blocked, the given velocities (n, 3)."""
    O = yade.Omega()
    for i, v in zip(ids.tolist(), vel):
        O.bodies[i].state.blockedDOFs = "xyzXYZ"
        O.bodies[i].state.vel = tuple(v)


def stretched_chain(strain, steps=100):
    """A bar alone, its spheres driven with the linear velocity field of a uniform strain rate:
    every link strained alike. Returns (chain, force on the last sphere, elongation)."""
    reset_scene()
    O = yade.Omega()
    chain = SteelChains(one_bar(0.3), R, Bond(5e6, 1e11), dt_floor=1e-7)
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    x0 = np.array([O.bodies[i].state.pos[0] for i in chain.ids.tolist()])
    rate = strain / (steps * O.dt)
    drive(chain.ids, np.outer(rate * x0, [1, 0, 0]))
    for _ in range(steps):
        O.step()
    drive(chain.ids, np.zeros((len(chain.ids), 3)))
    O.step()                                           # forces at the final positions
    x = np.array([O.bodies[i].state.pos[0] for i in chain.ids.tolist()])
    force = O.forces.f(int(chain.ids[-1]))[0]
    return chain, -force, (x[-1] - x[0]) - (x0[-1] - x0[0])


def test_bar_alone_in_tension_gives_ea_over_l():
    """Links in series along the bar, each E_s A_s / s: the bar's stiffness is E_s A_s / L."""
    chain, force, elongation = stretched_chain(1e-4)
    assert len(chain.links) == len(chain.ids) - 1      # neighbours only
    assert force / elongation == pytest.approx(E_S * A_S / 0.3, rel=1e-9)


def test_bars_do_not_shrink_the_p_wave_time_step():
    """The steel spheres' mass is scaled so that PWaveTimeStep is the concrete's; unscaled (the
    steel's own mass), the bar would have shrunk it."""
    reset_scene()
    O = yade.Omega()
    from yade import utils
    concrete = O.materials.append(yade.wrapper.CpmMat(
        young=33e9, poisson=0.2, frictionAngle=0.5, sigmaT=4.8e6, epsCrackOnset=1e-4,
        relDuctility=30, density=5000))
    grid = np.stack(np.meshgrid(np.arange(15), np.arange(3), np.arange(3), indexing="ij"),
                    -1).reshape(-1, 3) * 2 * R + R
    add_spheres(grid, np.full(len(grid), R), concrete)
    without = utils.PWaveTimeStep()
    bars = one_bar(0.26)
    bars.start[0], bars.end[0] = (0.02, 0.03, 0.03), (0.28, 0.03, 0.03)
    chain = SteelChains(bars, R, Bond(5e6, 1e11), dt_floor=without)
    assert chain.mass_scale[0] > 1
    assert utils.PWaveTimeStep() == pytest.approx(without, rel=1e-12)
    steel = O.bodies[int(chain.ids[0])].material
    own = steel.density / chain.mass_scale[0]
    assert R * math.sqrt(own / steel.young) < without


def test_pull_out_gives_the_bond_strength():
    """A bar along x with concrete spheres at the same x as each steel sphere, a = 2.4 R off
    the axis on ±y, ±z: only radial bond links (the next ones are √(a² + s²) > 3 R away), so
    a pull-out slides every link in shear. The force rises with the bond-slip stiffness
    k_slip π d L and stays at τ_b π d L once the links slide. Errors: the links turn by
    α = slip / a (shear force × cos α) and stretch by slip² / 2a (normal force × sin α):
    relative ≤ α² + k Δ³ / (a² F) at slip Δ."""
    reset_scene()
    O = yade.Omega()
    tau, k_slip, n = 5e6, 1e11, 8
    s, a = 2 * R, 2.4 * R
    bars = one_bar((n - 1) * s)
    concrete = O.materials.append(yade.wrapper.CpmMat(
        young=30e9, poisson=0.2, frictionAngle=0.5, sigmaT=3e6, epsCrackOnset=1e-4,
        relDuctility=30, density=2400))
    around = np.array([[0, a, 0], [0, -a, 0], [0, 0, a], [0, 0, -a]])
    centres = (np.arange(n)[:, None, None] * np.array([s, 0, 0]) + around).reshape(-1, 3)
    concrete_ids = add_spheres(centres, np.full(len(centres), R), concrete)
    chain = SteelChains(bars, R, Bond(tau, k_slip), dt_floor=1e-7)
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    assert chain.bond_links() == 4 * n
    drive(concrete_ids, np.zeros((len(concrete_ids), 3)))
    length = (n - 1) * s
    strength = tau * math.pi * D * length
    slip_yield = tau / k_slip
    v = 3 * slip_yield / 3000 / O.dt
    drive(chain.ids, np.tile([v, 0, 0], (len(chain.ids), 1)))
    force, slip = [], []
    x0 = O.bodies[int(chain.ids[0])].state.pos[0]
    for _ in range(3000):
        O.step()
        force.append(-sum(O.forces.f(i)[0] for i in chain.ids.tolist()))
        slip.append(O.bodies[int(chain.ids[0])].state.pos[0] - x0 - v * O.dt)
    force, slip = np.array(force), np.array(slip)
    alpha = slip[-1] / a
    k_link = k_slip * math.pi * D * s / 4
    tol = alpha**2 + k_link * slip[-1]**3 / (a**2 * strength / (4 * n))
    assert force[-1] == pytest.approx(strength, rel=tol)
    assert force.max() == pytest.approx(strength, rel=tol)
    early = slip < 0.5 * slip_yield
    stiffness = np.polyfit(slip[early], force[early], 1)[0]
    assert stiffness == pytest.approx(k_slip * math.pi * D * length, rel=tol)


def strip_deflection(layer, load=2e4, tol=2e-4, chunk=500, max_chunks=80):
    """Mid-span deflection of the small slab's DE strip in 3-point bending (cases.slab.bending's
    strip, supports, load and gauge; links undamaged), with the bars of `layer` if given, and
    the PWaveTimeStep without and with them."""
    from yade import utils
    from cases import slab
    from cases.slab import bending as sb
    from cases.reinforcement import bar_layout
    from yade_side.bulk import BodySet
    from yade_side.material import cpm_material
    O = yade.Omega()
    spec = slab.SlabSpec(scale="small")
    packs = slab.make_packings(spec)
    c, r = sb._strip(packs.slab_centres, packs.slab_radii)
    reset_scene()
    ids = add_spheres(c, r, cpm_material(slab.concrete(spec), packs.slab_fraction))
    dt_plain = utils.PWaveTimeStep()
    chain = None
    if layer is not None:
        y0 = 0.5 * (slab.SLAB[1] - sb.STRIP)
        bars = bar_layout([layer], (0, y0, 0), (slab.SLAB[0], y0 + sb.STRIP, slab.SLAB[2]))
        chain = SteelChains(bars, spec.radius, Bond(10e6, 1e11), dt_floor=dt_plain)
    dt_bars = utils.PWaveTimeStep()
    _, newton = cpm_engines(dt_safety=0.8)
    create_cohesive_links()
    if chain is not None:
        chain.bond_links()
    for i in O.interactions:
        i.phys.neverDamage = True
    newton.damping = 0.5
    block_dofs(ids[(c[:, 0] < 2 * r) | (c[:, 0] > slab.SLAB[0] - 2 * r)], "z")
    top = sb._top(c, r)
    for i in ids[top]:
        O.forces.setPermF(int(i), (0, 0, -load / top.sum()))
    w = sb.settled_deflection(BodySet(ids[sb._gauge(c)]), tol, chunk, max_chunks)
    return -w, dt_plain, dt_bars, chain


@pytest.mark.slow
def test_reinforced_de_strip_bends_like_the_transformed_section():
    """The small slab's DE strip (0.3 m wide, 2.5 m span, 0.28 m thick) with 3 bars of 20 mm at
    40 mm from the bottom: its stiffness gain over the plain strip matches the transformed
    section's I_t / I with n = E_s / E_b, E_b the plain strip's own bending modulus (the DE
    strip bends like ~20 GPa, cases/slab/scales.py), within 10 %; shear deformation is left out
    (span/depth 9: ~3 % of the deflection, on both strips alike). The bars leave
    PWaveTimeStep unchanged."""
    from cases.reinforcement import Layer, transformed_section
    from cases.slab.bending import fe_deflection, REFERENCE_E
    from cases import slab
    layer = Layer(diameter=0.02, spacing=0.1, direction="x", cover=0.04)
    plain, _, _, _ = strip_deflection(None)
    reinforced, dt_plain, dt_bars, chain = strip_deflection(layer)
    assert dt_bars == pytest.approx(dt_plain, rel=1e-12)
    e_b = REFERENCE_E * -fe_deflection(slab.SlabSpec(scale="small"), 2e4) / plain
    n_bars = len(chain.bars)
    _, inertia = transformed_section(0.3, 0.28, e_b, np.full(n_bars, 0.28 - 0.04),
                                     chain.bars.area, E_S)
    assert plain / reinforced == pytest.approx(inertia / (0.3 * 0.28**3 / 12), rel=0.1)
