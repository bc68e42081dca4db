"""Fracture energy of a CPM packing: a direct tension test carried to full separation.

Gf = energy dissipated by the links / ligament area, where
- the specimen is notched at mid-length on its two cut sides (y = 0, W: the cohesive links that
  cross the mid-plane within the notch depth n are deleted), so that the crack runs there and
  not next to a driven end, through the slab's faces (z) as a slab's crack does; unnotched, the
  0.56 m slab piece cracked next to an end group and kept 10 % of its peak stress through
  friction of the wedged end spheres up to a strain of 2e-3;
- the ligament area is the notched section (W − 2n) × T, the crack's projected area at full
  separation (Gf per projected area, as RILEM's work-of-fracture test defines it);
- the energy dissipated by the links is measured on the links and on the contacts made later
  (yade_side.dissipation: damage, slip and friction, what a deleted or released link takes),
  and the test's balance is checked: the external work W_ext = ∫ F dΔ of the end groups (F
  the mean of the two end forces, Δ the change of their distance; trapezoidal rule on every
  step) plus the initial kinetic energy of the free spheres must equal, within CLOSURE, the
  elastic energy left in the links, the kinetic energy of the free spheres, the energy taken
  by Cundall's damping (O.energy['nonviscDamp']: numerical, not fracture; the driven end
  groups are not damped) and the links' dissipation. A balance that does not close gives no
  Gf: a long step makes energy in cracked links (docs/calibration.md);
- full separation: the test goes on until |σ| has stayed below `residual` × the peak for as long
  a displacement as it took to reach the peak.

A direct tension test rather than the notched beam: the beam needs span ≥ 4 × depth, i.e. a
1.1 m long piece of the 0.28 m slab (twice the spheres of the 0.56 m tension specimen), and a
deflection to full separation of the order of millimetres; the tension test reuses the
calibration's specimen and strainer.

One CPM link in pure tension (ω = 1 − (ε0/κ) exp(−(κ − ε0)/εf), εf = relDuctility ε0,
σ = (1 − ω) E ε, deleted at the first step with ω > omegaThreshold) dissipates
A L0 E ε0² [1/2 + r (1 − exp(−(x* − 1)/r))], x* = κ*/ε0 where ω(κ*) = omegaThreshold:
see `link_work_density`.
"""
import math
import time

import numpy as np
from scipy.optimize import brentq

from yade_side import import_yade
from yade_side.bulk import BodySet
from yade_side.calibration import Loading, uniaxial_scene
from yade_side.dissipation import LinkMeter
from yade_side.distributed import elastic_energy
from yade_side.scene import BROKEN_OMEGA

RESIDUAL = 0.01     # full separation: |σ| below this × peak ...
SEPARATION_STRAIN = 1e-2   # ... reached before this strain between the ends, else not separated
NOTCH = 0.1         # notch depth on each cut side (y), × the width
MIN_DUCTILITY = 0.1  # relDuctility the fit goes down to (links break at ~1.5 ε0)
CLOSURE = 0.05      # the balance closes when what is found is within this × what went in


def mc2010_fracture_energy(fcm):
    """fib Model Code 2010 (5.1-9): Gf = 73 fcm^0.18 N/m, fcm the mean compressive strength (Pa
    here, MPa in the formula)."""
    if not fcm > 0:
        raise ValueError(f"compressive strength must be > 0, got {fcm!r}")
    return 73.0 * (fcm / 1e6) ** 0.18


def break_strain_ratio(rel_ductility, threshold=BROKEN_OMEGA):
    """x* = κ*/ε0 at which CPM's exponential damage ω(κ) reaches `threshold`:
    (1/x) exp(−(x − 1)/r) = 1 − threshold (unique root, the left side decreases from 1)."""
    if not rel_ductility > 0:
        raise ValueError(f"relDuctility must be > 0, got {rel_ductility!r}")
    if not 0 < threshold < 1:
        raise ValueError(f"damage threshold must be in (0, 1), got {threshold!r}")
    f = lambda x: -math.log(x) - (x - 1) / rel_ductility - math.log(1 - threshold)
    return brentq(f, 1.0, 1.0 / (1 - threshold), xtol=1e-14, rtol=1e-15)


def ductility_factor(rel_ductility, threshold=BROKEN_OMEGA):
    """g(r) = ∫σ dε / (E ε0²) of one link to its deletion: 1/2 (elastic branch) +
    ∫_1^x* exp(−(x − 1)/r) dx = 1/2 + r (1 − exp(−(x* − 1)/r)). Increases with r, towards
    1/2 + (1/(1 − threshold) − 1) (a plateau σ = E ε0 up to x* = 1/(1 − threshold))."""
    x = break_strain_ratio(rel_ductility, threshold)
    return 0.5 + rel_ductility * -math.expm1(-(x - 1) / rel_ductility)


def link_work_density(young, eps_crack_onset, rel_ductility, threshold=BROKEN_OMEGA):
    """Energy per unit link volume (A × L0) that one CPM link dissipates in tension to its
    deletion: E ε0² g(r) (J/m³)."""
    return young * eps_crack_onset ** 2 * ductility_factor(rel_ductility, threshold)


def ductility_for_factor(g, threshold=BROKEN_OMEGA):
    """relDuctility r in [MIN_DUCTILITY, 1e8] with g(r) = g (inverse of ductility_factor)."""
    g_min = ductility_factor(MIN_DUCTILITY, threshold)
    g_max = 0.5 + threshold / (1 - threshold)
    if not g_min <= g < g_max:
        raise ValueError(f"link energy factor must be in [{g_min:.4g}, {g_max:.4g}) "
                         f"(relDuctility ≥ {MIN_DUCTILITY}, links deleted at ω > {threshold}), "
                         f"got {g!r}")
    if g == g_min:
        return MIN_DUCTILITY
    return brentq(lambda r: ductility_factor(r, threshold) - g, MIN_DUCTILITY, 1e8, rtol=1e-13)


def notch_links(sample, notch):
    """Delete the cohesive links that cross the mid-plane x = x_mid within `notch` (m) of the
    cut sides y = 0, y = W: the crack starts there, not at the driven ends. Returns the
    ligament area (W − 2 notch) × T."""
    O = import_yade().Omega()
    width, thickness = sample.size[1], sample.size[2]
    if not 0 <= notch < width / 2:
        raise ValueError(f"notch depth must be in [0, {width / 2}) m, got {notch!r}")
    if notch > 0:
        x_mid = sample.centres[:, 0].mean()
        cut = []
        for I in O.interactions:           # set-up only
            a, b = O.bodies[I.id1].state.pos, O.bodies[I.id2].state.pos
            y = 0.5 * (a[1] + b[1])
            if (a[0] - x_mid) * (b[0] - x_mid) < 0 and (y < notch or y > width - notch):
                cut.append((I.id1, I.id2))
        for a, b in cut:
            O.interactions.erase(a, b)
    return (width - 2 * notch) * thickness


def separation_test(sample, params, loading=Loading(), material=None, residual=RESIDUAL,
                    max_strain=SEPARATION_STRAIN, notch=None, log=None):
    """Direct tension at loading.tension_rate until full separation, the cut sides notched at
    mid-length (`notch` m deep, default NOTCH × width). Returns a dict: strain,
    stress (sampled every loading.sample_strain / 10), peak (ft), strain_peak, work (J),
    elastic_end, kinetic (initial, end of the free spheres), damping (J), links (the links'
    dissipation by part, LinkMeter.dissipated), closure ((in − found) / in), area (m²),
    fracture_energy (J/m²: the links' dissipation / area; None when the balance does not close:
    `balance` says why), work_of_fracture (W_ext / area), separated, steps, dt, spheres,
    seconds."""
    if not 0 < residual < 1:
        raise ValueError(f"residual must be in (0, 1), got {residual!r}")
    yade = import_yade()
    O = yade.Omega()
    ids, strainer, gauge, pair = uniaxial_scene(sample, params, "tension", loading.tension_rate,
                                                loading, material)
    area = notch_links(sample, NOTCH * sample.size[1] if notch is None else notch)
    meter = LinkMeter()
    ends = set(strainer.posIds) | set(strainer.negIds)
    free = BodySet([i for i in ids.tolist() if i not in ends])
    # O.energy['nonviscDamp'] would count the damping of the driven ends' reaction forces
    for i in ends:
        O.bodies[i].state.isDamped = False
    O.trackEnergy = True
    kinetic0 = free.kinetic_energy() if len(free) else 0.0
    every = max(1, round(loading.sample_strain / 10 / (loading.tension_rate * O.dt)))
    section = sample.section            # the strainer's stress is force / section
    work, peak, d_peak, d_high = 0.0, 0.0, 0.0, 0.0
    s_old, d_old = strainer.avgStress, strainer.strain * pair
    strain, stress = [d_old / gauge], [s_old]
    t0, separated = time.perf_counter(), False
    while True:
        for _ in range(every):
            O.step()
            meter.sample()
            s, d = strainer.avgStress, strainer.strain * pair
            work += 0.5 * (s + s_old) * section * (d - d_old)
            s_old, d_old = s, d
            if s > peak:
                peak, d_peak = s, d
            if abs(s) > residual * peak:
                d_high = d
        strain.append(d / gauge)
        stress.append(s)
        meter.relist()
        if log is not None and len(strain) % 100 == 0:
            log(f"separation test: strain {d / gauge:.3e}, stress {s / 1e6:.3f} MPa "
                f"(peak {peak / 1e6:.3f}), work {work:.2f} J")
        if not math.isfinite(s):
            raise FloatingPointError(f"separation test: stress is {s} at step {O.iter}")
        if peak > 0 and d - d_high > d_peak:
            separated = True
            break
        if d / gauge > max_strain:
            break
    elastic = elastic_energy()
    free.read()
    kinetic = free.kinetic_energy() if len(free) else 0.0
    damping = float(O.energy["nonviscDamp"]) if "nonviscDamp" in O.energy.keys() else 0.0
    links = meter.dissipated()
    energy_in = work + kinetic0
    found = math.fsum((elastic, kinetic, damping, links["total"]))
    balance = balance_failure(energy_in, found)
    return dict(strain=np.array(strain), stress=np.array(stress), peak=peak,
                strain_peak=d_peak / gauge, work=work, elastic_end=elastic,
                kinetic=(kinetic0, kinetic), damping=damping, links=links,
                closure=(energy_in - found) / energy_in, area=area,
                fracture_energy=None if balance else links["total"] / area,
                balance=balance,
                work_of_fracture=work / area, separated=separated, steps=O.iter, dt=O.dt,
                spheres=len(ids), seconds=time.perf_counter() - t0)


def balance_failure(energy_in, found):
    """Why the balance gives no Gf (None when it closes: `found`, the elastic, kinetic, damping
    and the links' dissipation, within CLOSURE of what went in). More found than went in:
    energy was made inside the specimen (the CPM law's cracked links at a long step make it,
    docs/calibration.md); less: a loss the links' measure does not see."""
    off = (found - energy_in) / energy_in
    if abs(off) <= CLOSURE:
        return None
    return (f"the balance does not close: the energy found at the end (elastic, kinetic, "
            f"damping, the links' dissipation: {found:.4g} J) is {100 * off:+.1f} % off what the "
            f"ends put in ({energy_in:.4g} J; limit {100 * CLOSURE:.0f} %)"
            + (": energy was made inside the specimen" if off > 0 else "")
            + ", so no fracture energy")


def next_ductility(history, wanted, threshold=BROKEN_OMEGA):
    """relDuctility for the next fit iteration, or None if the target is out of reach.
    history: (relDuctility, φ) of the past iterations, φ = Gf / (young ε0²), which depends on r
    only (at a fixed packing and ξ, quasi-statically: the link law scales with young ε0 in
    stress and ε0 in strain); wanted: the φ of the target. With one point φ ∝ g(r) (the links'
    energy); with more, a secant step on log φ against log g through the last two distinct
    points. Out of reach: the step asks for g beyond what links can have (relDuctility below
    MIN_DUCTILITY, or links that never break), from a point already at that bound."""
    g = [ductility_factor(r, threshold) for r, _ in history]
    phi = [p for _, p in history]
    slope = 1.0
    if len(history) > 1 and g[-2] != g[-1] and phi[-2] != phi[-1]:
        slope = math.log(phi[-1] / phi[-2]) / math.log(g[-1] / g[-2])
        slope = slope if slope > 0 else 1.0     # φ grows with g; noise must not reverse it
    g_next = g[-1] * (wanted / phi[-1]) ** (1.0 / slope)
    g_min = ductility_factor(MIN_DUCTILITY, threshold)
    g_max = (0.5 + threshold / (1 - threshold)) * (1 - 1e-9)
    bounded = min(max(g_next, g_min), g_max)
    if bounded != g_next and bounded == g[-1]:
        return None
    return ductility_for_factor(bounded, threshold)
