"""The energy dissipated by cracking, per element, against independent known answers: per CPM
link (yade_side.cracking) the link meter's step-by-step measure (yade_side.dissipation) on
links pulled, unloaded, compressed and pulled again, to near-full damage and to deletion, and
the closed form itself against YADE's own damage function; per FE cell
(DamageModel.dissipated_cells) the closed form along one cell's tension-compression cycle,
the total, and Gf × the section in a bar's crack."""
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from yade_side import import_yade
from yade_side.cracking import cracking_density, link_cracking_energy
from yade_side.dissipation import LinkMeter
from yade_side.scene import cpm_law

from test_fe_damage import LAW, RHO, box, pull_bar, set_linear, uniaxial, uniaxial_law
from test_fracture import held_spheres

yade = import_yade()
O = yade.Omega()
# held_spheres' links: E, ε0, εf = relDuctility ε0, spheres of radius R linked 2 R apart
R, E, E0, EF = 0.01, 30e9, 1e-4, 5e-4
L0, VOLUME = 2 * R, math.pi * R ** 2 * 2 * R


def omega_rate(kappa):
    """ω'(κ) of CPM's exponential damage past ε0."""
    return (E0 / kappa) * (1 / kappa + 1 / EF) * math.exp(-(kappa - E0) / EF)


def trapezoid_bound(volume, h, starts):
    """How far the meter's trapezoidal rule on Y dω (Y = ½ E ε², ε = κ while ω grows) may be
    from the integral, for a link strained by a constant h per step whose damage grows from
    each κ_s of `starts` (ε0, then where a reload passes the history): per stretch of growth,
    the composite rule's (h³/12) E (ω' − κ ω'') per step sums to (E h²/12) [2ω − κω'] between
    its ends, at most (E h²/12) (3 + ε0/εf) (0 ≤ κω' ≤ 1 + ε0/εf); and on the step where it
    starts, Y is between its two ends' values and ω grows by at most h ω'(κ_s) (ω' falls past
    ε0): ½ E (κ_s + h) h × h ω'(κ_s). Leading order in h."""
    return volume * sum(E * h ** 2 / 12 * (3 + E0 / EF)
                        + 0.5 * E * (k + h) * h ** 2 * omega_rate(k) for k in starts)


def pull(meter, velocities, steps):
    """Move the held spheres at `velocities` (x, one per body) for `steps` steps, the meter
    sampling every step."""
    for body, v in enumerate(velocities):
        O.bodies[body].state.vel = (v, 0, 0)
    for _ in range(steps):
        O.step()
        meter.sample()


def test_the_closed_form_is_the_envelope_work_less_the_stored_energy():
    """g(κ) = ∫_0^κ σ dε − ½ (1 − ω) E κ², σ = (1 − ω) E ε on the envelope, with YADE's own
    funcG: the trapezoidal rule over 40,000 steps h of ε past ε0 (exact below; error ≤
    (κ − ε0) h² max|σ''| / 12, σ'' = E ε0 e / εf² ≤ E ε0 / εf²); 0 up to ε0."""
    funcG = yade.wrapper.CpmPhys.funcG
    for x in (1.5, 4.0, 30.0):
        eps = np.concatenate([np.linspace(0, E0, 3), np.linspace(E0, x * E0, 40001)[1:]])
        omega = np.array([funcG(e, E0, EF) for e in eps])
        h = (x - 1) * E0 / 40000
        stored = 0.5 * (1 - omega[-1]) * E * eps[-1] ** 2
        assert cracking_density(E, E0, EF, x * E0) == pytest.approx(
            np.trapz((1 - omega) * E * eps, eps) - stored,
            abs=(x - 1) * E0 * h ** 2 * E * E0 / EF ** 2 / 12)
    assert cracking_density(E, E0, EF, np.array([0.0, 0.5 * E0, E0])).tolist() == [0, 0, 0]


def test_link_energies_are_the_meters_on_a_chain_pulled_unloaded_and_pulled_again():
    """Four held spheres on x, weighted (β 1, ½, ½, 1: the links' sections × ¾, ½, ¾). Link
    0-1 strained 0 → 3 ε0 → −ε0 → 5.98 ε0 by h = ε0/50 per step, link 1-2 to ε0/2 only, link
    2-3 as 0-1 but neverDamage. The closed form of 0-1 from its κ alone equals what the meter
    summed over the whole path (damage grows from ε0, then again from 3 ε0) within the
    trapezoidal rule's bound; the two others dissipated exactly 0; the weight is the
    section's."""
    from yade_side.weighting import weight_links
    ids = held_spheres([(0, 0, 0), (2 * R, 0, 0), (4 * R, 0, 0), (6 * R, 0, 0)], R)
    weight_links(np.array(ids), np.array([1.0, 0.5, 0.5, 1.0]))
    O.interactions[2, 3].phys.neverDamage = True
    meter = LinkMeter()
    h = E0 / 50
    v = h * L0 / O.dt
    pull(meter, (0, v, 7 * v / 6, 13 * v / 6), 150)
    pull(meter, (0, -v, -v, -2 * v), 200)
    pull(meter, (0, v, v, 2 * v), 350)
    found = link_cracking_energy()
    assert found.ids.tolist() == [[0, 1], [1, 2], [2, 3]]
    kappa = O.interactions[0, 1].phys.kappaD
    assert kappa == pytest.approx(5.98 * E0, rel=1e-9)       # the law lags a step
    assert found.energy[1] == 0.0 and found.energy[2] == 0.0
    assert found.energy[0] == pytest.approx(
        0.75 * VOLUME * cracking_density(E, E0, EF, kappa), rel=1e-12)
    assert meter.dissipated()["shear"] == 0
    assert abs(found.energy[0] - meter.damage) <= trapezoid_bound(0.75 * VOLUME, h,
                                                                  (E0, 3 * E0))


def test_a_link_pulled_to_nearly_full_damage_dissipates_its_fracture_work():
    """Two spheres, the law keeping links at any damage (omegaThreshold 1), pulled to κ = 40
    ε0 (ω = 0.9996) by h = ε0/20 per step: the closed form is the full fracture work
    V E ε0² (½ + εf/ε0) less E ε0 e (εf + κ/2) V (0.2 % of it), the meter's measure is it within
    the trapezoidal rule's bound, and at_break (never deleted) is the full work."""
    held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    cpm_law().omegaThreshold = 1.0
    meter = LinkMeter()
    h = E0 / 20
    pull(meter, (0, h * L0 / O.dt), 801)
    found = link_cracking_energy()
    phys = O.interactions[0, 1].phys
    kappa = phys.kappaD
    assert kappa == pytest.approx(40 * E0, rel=1e-9) and phys.omega > 0.9995
    full = VOLUME * E * E0 ** 2 * (0.5 + EF / E0)
    remaining = VOLUME * E * E0 * math.exp(-(kappa - E0) / EF) * (EF + kappa / 2)
    assert remaining < 2e-3 * full
    assert found.energy[0] == pytest.approx(full - remaining, rel=1e-12)
    assert abs(found.energy[0] - meter.damage) <= trapezoid_bound(VOLUME, h, (E0,))
    assert abs(meter.damage - full) <= remaining + trapezoid_bound(VOLUME, h, (E0,))
    assert found.at_break[0] == pytest.approx(full, rel=1e-15)


def test_a_deleted_link_is_kept_at_its_work_to_deletion():
    """Two spheres pulled by h = ε0/50 per step until the law deletes their link (ω > 0.99):
    given the result from before, the link is still listed, at its at_break, which is what the
    meter found its damage and deletion took (W(κ_del) V) within the trapezoidal rule's bound
    and the work past κ* of the step that deleted it (≤ (1 − 0.99) E κ* h V); a link never
    strained dissipated 0."""
    from yade_side.fracture import break_strain_ratio
    held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    before = link_cracking_energy()
    assert before.energy.tolist() == [0.0]
    meter = LinkMeter()
    h = E0 / 50
    O.bodies[1].state.vel = (h * L0 / O.dt, 0, 0)
    while O.interactions.countReal() and O.iter < 2000:
        O.step()
        meter.sample()
    assert link_cracking_energy().ids.shape == (0, 2)
    after = link_cracking_energy(before)
    assert after.ids.tolist() == [[0, 1]] and after.energy[0] == before.at_break[0]
    measured = meter.dissipated()
    assert measured["deleted_count"] == 1 and measured["deleted"] > 0
    kappa_break = break_strain_ratio(EF / E0) * E0
    assert abs(after.energy[0] - measured["damage"] - measured["deleted"]) <= (
        trapezoid_bound(VOLUME, h, (E0,)) + 0.01 * E * kappa_break * h * VOLUME)


def test_the_meter_holds_the_elastic_energy_of_a_stretched_and_a_sheared_link():
    """Two held spheres, the link stretched by ε0/2 (undamaged) and then sheared along y: it
    holds ½ E ε² V + ½ G |εT|² V (G = E × CpmMat.poisson, YADE's ks/kn), to round-off; no
    energy is dissipated (no damage, no slip below the cohesion); a link gone holds none."""
    held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    meter = LinkMeter()
    pull(meter, (0, 0.5 * E0 * L0 / (10 * O.dt)), 10)
    O.bodies[1].state.vel = (0, 1e-3 * E0 * L0 / (10 * O.dt), 0)
    for _ in range(10):
        O.step()
        meter.sample()
    phys = O.interactions[0, 1].phys
    eps, eps_t = phys.epsN, np.array(phys.epsT)
    assert eps == pytest.approx(0.5 * E0, rel=1e-6) and np.linalg.norm(eps_t) > 0
    alive = meter.alive()
    expected = 0.5 * VOLUME * (E * eps ** 2 + E * 0.2 * eps_t @ eps_t)
    assert meter.stored(alive)[0] == pytest.approx(expected, rel=1e-12)
    parts = meter.per_interaction(alive)
    assert parts["damage"][0] == 0 and parts["plastic"][0] == 0
    assert abs(parts["shear"][0]) <= 1e-12 * expected       # the trapezoid is exact: linear
    assert meter.stored(~alive)[0] == 0


def test_a_restored_meter_carries_on_as_if_never_stopped():
    """The meter's state() restored on the same scene reads on from where it was: after ten
    more steps its per-link figures equal those of the meter that never stopped, bit for bit;
    a link the scene no longer has keeps what it had."""
    held_spheres([(0, 0, 0), (2 * R, 0, 0), (4 * R, 0, 0)], R)
    meter = LinkMeter()
    start = meter._last.copy()          # the history blocks an earlier version kept
    pull(meter, (0, E0 * L0 / (10 * O.dt), 0), 40)
    again = LinkMeter.restored(meter.state())
    # a state written by the earlier version: the start's blocks, no search step
    state = {k: v for k, v in meter.state().items() if k not in ("start_shear", "listed_at")}
    older = LinkMeter.restored({**state, "start": start})
    for _ in range(10):
        O.step()
        for m in (meter, again, older):
            m.sample()
    alive = meter.alive()
    for other in (again, older):
        assert other.relist() == 0
        for a, b in zip(meter.per_interaction(alive).values(),
                        other.per_interaction(alive).values()):
            assert a.tobytes() == b.tobytes()
    assert meter.damage > 0
    O.interactions.erase(0, 1)
    gone = LinkMeter.restored(meter.state())
    gone.sample()
    assert gone.alive().tolist() == [False, True]
    before = meter.per_interaction(alive)["damage"][0]
    assert gone.per_interaction(gone.alive())["damage"][0] == before


def test_a_linear_damage_law_is_refused_in_one_line():
    held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    O.materials[0].damLaw = 0
    with pytest.raises(ValueError, match=r"^CpmMat \[0\] has damLaw 0 \(linear softening\)"):
        link_cracking_energy()


# --- FE cells ---------------------------------------------------------------------------------
def test_one_cell_dissipates_the_closed_form_along_a_tension_compression_cycle():
    """One box cell (uniform strain: no higher-order part) in uniaxial stress: tension to
    40 κ0, compression past fc (the crack shut, D_c growing), tension to 30 κ0. Y = ½ E e² on
    either sign, D_t of κ_t = max e and D_c of κ_c = max(−e)/k have the exponential form, so
    the cell has dissipated V [g(κ_t; E, ε_f) + g(κ_c; E k², ε_fc)]. The kernel takes each
    step's end Y × its ΔD: above that by at most Σ (Y_b − Y_a) ΔD over the growing steps
    (both grow along a step), with the law's D and ε_f of a 0.05 m cell (uniaxial_law); not
    below it but for the law's strains, which test_fe_damage holds to 1e-6."""
    from fenicsx_side.damaged import DamageModel
    m = DamageModel(box([0, 0, 0], [0.05, 0.05, 0.05], [1, 1, 1]), LAW, RHO)
    k0, ec, k = LAW.kappa0, LAW.compressive_strength / LAW.young, LAW.strength_ratio
    path = np.concatenate([np.linspace(0, 40 * k0, 400), np.linspace(40 * k0, -3 * ec, 200),
                           np.linspace(-3 * ec, 30 * k0, 200)])
    bound, last = 0.0, (0.0, 0.0, 0.0)
    for e, dt, dc, _ in uniaxial_law(path):
        set_linear(m, uniaxial(e))
        m.update_damage()
        bound += 0.5 * LAW.young * (e ** 2 - last[0] ** 2) * (dt - last[1] + dc - last[2])
        last = (e, dt, dc)
    ef = LAW.constrained_ratio * LAW.fracture_energy / (0.05 * LAW.tensile_strength) - k0 / 2
    efc = (LAW.compressive_fracture_energy / (0.05 * LAW.compressive_strength)
           - 0.5 * ec) / k
    exact = m.cell_volume[0] * (cracking_density(LAW.young, k0, ef, 40 * k0)
                                + cracking_density(LAW.young * k ** 2, k0, efc, 3 * ec / k))
    assert m.damage_t[0] > 0.999 and m.damage_c[0] > 0.5
    assert m.dissipated_cells.tolist() == [m.dissipated]
    assert -1e-6 * exact <= m.dissipated - exact <= m.cell_volume[0] * bound
    assert m.cell_volume[0] * bound < 0.05 * exact
    restored = DamageModel(box([0, 0, 0], [0.05, 0.05, 0.05], [1, 1, 1]), LAW, RHO)
    restored.restore_history({name: v.copy() for name, v in m.history().items()})
    assert np.array_equal(restored.dissipated_cells, m.dissipated_cells)


def test_a_bar_pulled_apart_keeps_gf_times_its_section_in_its_cracked_cell():
    """The notched bar of 8 cells pulled to full separation: the cells' energies sum to the
    total to rounding, the cells that never damaged hold exactly 0, the cracked cell Gf × the
    section within 5 % (the total's tolerance in test_fe_damage). Its half x < 0.2 made a
    model of its own (take_state, as a grown zone's FE part): each cell keeps its energy, the
    total keeps what the cells given up had dissipated."""
    from fenicsx_side.damaged import DamageModel
    m, _, _, area = pull_bar(8)
    cells = m.dissipated_cells
    assert cells.sum() == pytest.approx(m.dissipated, rel=1e-14)
    assert np.all(cells[m.damage == 0] == 0) and np.count_nonzero(m.damage == 0) >= 5
    cracked = np.argmax(m.damage)
    assert m.damage[cracked] > 0.99 and abs(m.cell_centres[cracked, 0] - 0.2) < 0.05
    assert cells[cracked] == pytest.approx(LAW.fracture_energy * area, rel=0.05)
    msh = box([0, 0, 0], [0.2, 0.05, 0.05], [4, 1, 1])
    x = msh.geometry.x
    middle = np.isclose(x[:, 0], 0.2)                               # pull_bar's notch
    x[middle, 1:] = 0.025 + 0.99 * (x[middle, 1:] - 0.025)
    part = DamageModel(msh, LAW, RHO)
    nodes = cKDTree(m.nodes).query(part.nodes)[1]
    kept = cKDTree(m.cell_centres).query(part.cell_centres)[1]
    part.take_state(m, nodes, kept)
    assert np.array_equal(part.dissipated_cells, cells[kept])
    assert np.all(m.cell_centres[kept, 0] < 0.2) and len(np.unique(kept)) == 4
    assert part.dissipated == m.dissipated
    assert part.dissipated - part.dissipated_cells.sum() == pytest.approx(
        np.delete(cells, kept).sum(), rel=1e-12, abs=1e-15 * m.dissipated)
