"""Reinforcement bars in the DE model: chains of spheres linked by an elastic CPM law, bonded to
the concrete spheres by CPM links that carry the bond's strength.

Debian's YADE 2023.02a links CpmMat spheres only to CpmMat spheres by a cohesive law (CpmMat with
another material gets a frictional contact only), so the steel is a CpmMat too, with
neverDamage: its links never break and have no bending or twisting stiffness (CPM has no
contact moments: the chain carries axial force only, like the FE side's truss, no dowel
action). They yield by the bars' law (`Bars.steel_step`): CPM's normal strain of a link is
ε_N = (d − d0 + refPD − refPD0) / L0 (d the centres' distance, 0 when it was made), so the
plastic strain ε_p of a link is refPD = refPD0 − ε_p L0. `SteelChains.plastic_step`, after
every step, reads the chain spheres' positions in bulk, maps the links' strains back onto
the law and writes refPD of the links whose plastic strain changed: the next step's forces
are the law's at those positions.

- Steel links: spheres of radius r on each bar axis, `spacing` ≈ 2 r apart (1.5 r < s < 3 r:
  neighbours linked, next neighbours not). CPM's link stiffness is young π r² / s, so
  young = E_s A_s / (π r²) gives the chain the bar's E_s A_s / s.
- Mass: ρ_s A_s s per sphere, the bar's ends too (half a spacing more than the bar at each
  end: halving their mass would halve their PWaveTimeStep, which YADE takes from the mass),
  scaled up (`mass_scale` ≥ 1) if needed so that the steel spheres'
  PWaveTimeStep, r √(ρ/young), is not below `dt_floor` (the concrete's): the bars do not shrink
  the time step the slab takes from PWaveTimeStep. PWave = √(3 r / 4 s) √(m/k) here, below the
  chain's own critical step √(m/k), so the chain is stable at that step.
- Bond links (made in the first step with the concrete spheres within 1.5 (r + R)): the
  concrete is kept where the steel overlaps it, as the FE bars overlap the FE concrete. For a
  steel sphere of tributary length ℓ (s, s/2 at the bar ends) and bond surface π d ℓ, its m bond
  links share the bond-slip stiffness k_slip π d ℓ (normal and shear alike) and a yield force F
  each, frictionless (no confinement effect), with Σ F sin θ = τ_b π d ℓ (θ the angle between
  link and bar): once every link slides, the shear parts resist a pull-out with exactly τ_b per
  unit bar surface. The normal parts of oblique links resist elastically (compression) or crack
  at F (tension): in a random packing they add an interlock term that grows with the slip.
"""
import math
from dataclasses import dataclass

import numpy as np

from yade_side import import_yade

STEEL_SHEAR_RATIO = 0.2     # CpmMat.poisson of the steel links (shear/normal stiffness)
# YADE makes an interaction only between bodies whose masks share a bit: the steel spheres
# keep the default mask, the concrete that embeds them gets both bits, other bodies (e.g. an
# impactor) the second bit only (see shield_bars)
STEEL_MASK, OTHER_MASK = 1, 2
NO_SLIP = 1e30              # steel links' cohesion (Pa): never reached


@dataclass
class Bond:
    strength: float             # τ_b (Pa), per unit bar surface
    slip_stiffness: float       # Pa/m: bond stress per slip, per unit bar surface
    rel_ductility: float = 30.0 # softening of the bond links' tension damage (CPM relDuctility)

    def __post_init__(self):
        for name in ("strength", "slip_stiffness", "rel_ductility"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"bond {name} must be a positive number, got {v!r}")


def chain_centres(bars, radius):
    """Sphere centres along each bar: n = round(L / 2r) + 1 spheres from end to end. Returns
    (centres (N, 3), bar index (N,), spacing per bar (n_bars,), tributary length (N,))."""
    if not radius > 0:
        raise ValueError(f"bar sphere radius must be > 0, got {radius!r}")
    n = np.maximum(2, np.rint(bars.length / (2 * radius)).astype(int) + 1)
    spacing = bars.length / (n - 1)
    bad = np.flatnonzero((spacing <= 1.5 * radius) | (spacing >= 3 * radius))
    if bad.size:
        raise ValueError(f"bar {bad[0]} of length {bars.length[bad[0]]!r} m cannot be a chain of "
                         f"spheres of radius {radius!r} m (spacing {spacing[bad[0]]!r} m)")
    centres, bar_of, tributary = [], [], []
    for i, k in enumerate(n):           # per bar: set-up only
        s = np.linspace(0.0, 1.0, k)[:, None]
        centres.append(bars.start[i] + s * (bars.end[i] - bars.start[i]))
        bar_of.append(np.full(k, i))
        t = np.full(k, spacing[i])
        t[[0, -1]] /= 2
        tributary.append(t)
    return (np.concatenate(centres), np.concatenate(bar_of), spacing,
            np.concatenate(tributary))


class SteelChains:
    """Adds the bars' spheres to the scene (call before create_cohesive_links); after it, call
    bond_links() once to give the steel–concrete links the bond law.
    Attributes: ids (N,) steel sphere ids, bar (N,), mass_scale (n_bars,), links (pairs of
    steel ids, bar index) of the chains."""

    def __init__(self, bars, radius, bond, dt_floor):
        yade = import_yade()
        from yade import utils
        O = yade.Omega()
        if not dt_floor > 0:
            raise ValueError(f"dt_floor must be > 0, got {dt_floor!r}")
        self.bars, self.radius, self.bond = bars, float(radius), bond
        centres, self.bar, self.spacing, self.tributary = chain_centres(bars, radius)
        young = bars.young * bars.area / (math.pi * radius ** 2)
        volume = 4.0 / 3.0 * math.pi * radius ** 3
        density = bars.density * bars.area * self.spacing / volume
        needed = young * (dt_floor / radius) ** 2    # PWave = r √(ρ/E) = dt_floor
        self.mass_scale = np.maximum(1.0, needed / density)
        materials = [O.materials.append(yade.wrapper.CpmMat(
            young=float(young[i]), poisson=STEEL_SHEAR_RATIO, frictionAngle=0.5,
            sigmaT=NO_SLIP, epsCrackOnset=1.0, relDuctility=1.0,
            density=float(density[i] * self.mass_scale[i]), neverDamage=True))
            for i in range(len(bars))]
        self.ids = np.asarray(O.bodies.append([
            utils.sphere(tuple(c), self.radius, material=materials[b])
            for c, b in zip(centres, self.bar)]), dtype=int)
        ends = [(j, j + 1) for j in range(len(self.ids) - 1) if self.bar[j] == self.bar[j + 1]]
        self._ends = np.array(ends, int).reshape(-1, 2)
        self.links = [(int(self.ids[a]), int(self.ids[b]), int(self.bar[a])) for a, b in ends]
        self.link_bar = self.bar[self._ends[:, 0]]
        self.steel = None           # the links' plastic state, once they exist

    def start_plasticity(self, weight=None):
        """Read each chain link's reference (set-up only: the links must exist). Where it was
        made, the link's centres were d0 = 2 r − refPD0 apart (ScGeom's penetration depth).
        `weight`: each link's share of its bar (β), for the plastic work (default 1)."""
        from yade_side.bulk import BodySet
        O = import_yade().Omega()
        phys = [O.interactions[a, b].phys for a, b, _ in self.links]
        self._ref_pd = np.array([p.refPD for p in phys])
        self._ref_length = np.array([p.refLength for p in phys])
        self._ref_distance = 2 * self.radius - self._ref_pd
        self._spheres = BodySet(self.ids)
        share = np.ones(len(self.links)) if weight is None else np.asarray(weight, float)
        self.steel = self.bars.steel_state(
            self.link_bar, share * self.bars.area[self.link_bar] * self._ref_length)

    def strain(self):
        """The chain links' total axial strains (d − d0) / L0 now."""
        pos = self._spheres.read()[:, :3]
        d = np.linalg.norm(pos[self._ends[:, 1]] - pos[self._ends[:, 0]], axis=1)
        return (d - self._ref_distance) / self._ref_length

    def plastic_step(self):
        """The law at the links' strains now (call after each step); returns the number of
        links whose plastic strain changed."""
        before = self.steel.plastic.copy()
        self.steel.step(self.strain())
        changed = np.flatnonzero(self.steel.plastic != before)
        if changed.size:
            self._write_reference(changed)
        return changed.size

    def _write_reference(self, links):
        O = import_yade().Omega()
        ref = self._ref_pd - self.steel.plastic * self._ref_length
        for k in links.tolist():            # the links that yielded in this step only
            a, b, _ = self.links[k]
            O.interactions[a, b].phys.refPD = float(ref[k])

    def bond_links(self):
        """Give every steel–concrete link the bond law (see the module's docstring); returns the
        number of bond links. Steel–steel links keep the steel law."""
        O = import_yade().Omega()
        steel = set(self.ids.tolist())
        d = self.bars.diameter
        count = 0
        for j, i in enumerate(self.ids.tolist()):        # set-up only
            b = self.bar[j]
            t = self.bars.axis[b]
            links = [I for I in O.interactions.withBody(i)
                     if I.isReal and (I.id2 if I.id1 == i else I.id1) not in steel]
            if not links:
                raise ValueError(f"steel sphere {i} of bar {b} at "
                                 f"{list(O.bodies[i].state.pos)} has no concrete within reach")
            normal = np.array([tuple(I.geom.normal) for I in links])
            sin = np.sqrt(np.maximum(0.0, 1.0 - (normal @ t) ** 2))
            surface = math.pi * d[b] * self.tributary[j]
            if not sin.sum() > 0:
                raise ValueError(f"steel sphere {i} of bar {b}: no bond link crosses the bar")
            force = self.bond.strength * surface / sin.sum()
            k = self.bond.slip_stiffness * surface / len(links)
            for I in links:
                p = I.phys
                # CPM: normal strain Δ / L0, shear strain u_s / L0, where ScGeom's u_s is the
                # slip × (R1 + R2) / distance (measured with a radial link: 2R / 2.4R)
                p.E = k * p.refLength / p.crossSection
                p.G = p.E * p.refLength / (I.geom.refR1 + I.geom.refR2)
                p.kn = p.ks = k
                p.undamagedCohesion = force / p.crossSection
                p.tanFrictionAngle = 0.0
                p.neverDamage = False
                p.epsCrackOnset = force / (k * p.refLength)     # tensile strength: F too
                p.epsFracture = self.bond.rel_ductility * p.epsCrackOnset
            count += len(links)
        return count

    def steel_stress(self):
        """Axial stress Fn / A_s (Pa, tension > 0 as CPM's Fn) of every chain link as YADE
        computed it (a weighted link's is its share β of the bar's), 0 where a link is gone.
        A loop over the chains' links: for checks, not for the time loop."""
        O = import_yade().Omega()
        area = self.bars.area
        out = np.empty(len(self.links))
        for k, (a, b, bar) in enumerate(self.links):
            I = O.interactions[a, b]
            out[k] = I.phys.Fn / area[bar] if I.isReal else 0.0
        return out


def shield_bars(concrete_ids, other_ids):
    """The bars are reached through the concrete only: the spheres `concrete_ids` meet the
    steel spheres and the bodies `other_ids`, these do not meet the steel. Spheres of the bar's
    size 2 R sit closer to the face than the concrete's top spheres' valleys, where an
    impactor's spheres rest: they would be hit first. Once the concrete over a bar is gone,
    the impactor passes through it (set-up only: a loop over the bodies)."""
    O = import_yade().Omega()
    for i in np.asarray(concrete_ids, int).tolist():
        O.bodies[i].mask = STEEL_MASK | OTHER_MASK
    for i in np.asarray(other_ids, int).tolist():
        O.bodies[i].mask = OTHER_MASK
