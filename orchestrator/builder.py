"""The one builder: a description of a model (its DE scene, its FE part, the DE zone and
bridging band, the weighting, the multipliers) becomes the two partners, the coupling and the
stepper. Every case, the case-file runner and the benchmark build through `assemble`; the
same model with another DE zone is the same call with another `bridging`. `Model` is the run
loop's view of what was built.

The order matters and is the same for every model:
1. the FE part (α inside its stiffness and mass for the consistent weighting);
2. the DE scene's bodies (only the spheres a coupled model keeps), then the description's
   `bars` (steel spheres: weighted and coupled like the others, not measured);
3. the checks that need both: spheres in the band, each inside an FE cell, the time step;
4. β inside the sphere masses (consistent), the engines, the cohesive links (and the bars'
   bonds), and β inside the links once they exist (or right after the first step when the
   scene's script makes them: links made at rest carry no force in that step, so the result
   is the same);
5. the coupling of the band's spheres to the FE part, and the stepper.
"""
from dataclasses import dataclass, field
from time import perf_counter
from typing import Callable, Optional

import numpy as np

from orchestrator.coupling.assembly import bridging_spheres, make_coupling, time_step
from orchestrator.coupling.bridging import check_weighting
from orchestrator.coupling.correction import VARIANTS
from orchestrator.coupling.relaxation import (MAX_LAYERS, RELAXATION_RULES, Prediction,
                                              auto_layers, auto_relaxation, margin)
from orchestrator.stepper import CoupledStepper


class BuildError(ValueError):
    """Problems found while building, all of them (each one line)."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("; ".join(self.problems))


@dataclass
class CouplingSpec:
    variant: str = "diagonal"       # multiplier solver: full | diagonal
    relaxation: object = "auto"     # r, "auto" (orchestrator.coupling.relaxation) or "rho"
    rotations: bool = True          # couple sphere rotations too
    weighting: str = "consistent"   # or "nodal", the paper's (not conservative: docs/coupling.md)

    def __post_init__(self):
        if self.variant not in VARIANTS:
            raise ValueError(f"coupling variant must be one of {VARIANTS}, got {self.variant!r}")
        check_weighting("coupling", self.weighting)
        if self.relaxation not in RELAXATION_RULES and not (
                isinstance(self.relaxation, (int, float)) and self.relaxation > 0):
            raise ValueError(f"relaxation must be > 0, 'auto' or 'rho', got "
                             f"{self.relaxation!r}")

    @property
    def consistent(self):
        return self.weighting == "consistent"


@dataclass
class Description:
    scene: object                          # orchestrator.contracts.DEScene
    fe: Optional[Callable] = None          # fe(weight) -> FE partner; None: the DE model alone
    bridging: object = None                # orchestrator.coupling.bridging.Bridging (or alike)
    coupling: CouplingSpec = field(default_factory=CouplingSpec)
    dt_safety: float = None                # dt = dt_safety × the smaller critical step, ...
    dt: float = None                       # ... or this dt (else the scene's), checked
    dt_source: str = "dt"                  # what set `dt`, for the messages
    uncoupled: Optional[Callable] = None   # mask of band spheres left uncoupled (prescribed)
    band_tol: float = 0.0                  # the band widened by this (spheres on its faces)
    bars: object = None                    # DE members that are not measured (contracts.DEBars)


@dataclass
class Parts:
    """What `assemble` makes of a description."""
    O: object                  # YADE's Omega
    ids: np.ndarray            # the model's spheres (measured; the band's are coupled)
    fe: object                 # FE partner, or None for the DE model alone
    bridging: object
    beta: np.ndarray           # β of every sphere (1 where only spheres are)
    bridge_index: np.ndarray   # the coupled spheres of `ids`, into `ids`
    bar_ids: np.ndarray        # the bars' spheres: weighted and coupled, not measured
    stepper: object            # CoupledStepper, or None
    dt: float
    critical: dict
    relaxation: float          # r as resolved (None without coupling)
    notes: list
    inside_step: bool          # the coupling runs inside O.step (after the integrator)
    links_pending: bool        # the first step makes the cohesive links
    consistent: bool
    bars: object = None        # the DE members of the description (contracts.DEBars), or None
    scene: object = None       # the description's DE scene
    unweighted: tuple = None   # (mass, inertia) of every sphere of `ids` before any weighting
    ref_pos: np.ndarray = None  # reference positions of `ids` where they are not read at build
    new_links: object = None   # the links a zone grown in place made (scene.NewLinks)
    initial_links: np.ndarray = None   # (m, 2) ids of the initial links, where not read
    spheres: object = None     # the BodySet of `ids` at `ref_pos`, where the builder made it


def assemble(d, grown_from=None):
    """The partners, the coupling and the stepper of the description `d`; raises BuildError
    with every problem found before anything is stepped. With `grown_from` (a Model), `d` is
    that model's with a larger DE zone, built in its YADE scene (assemble_grown)."""
    if grown_from is not None:
        return assemble_grown(d, grown_from)
    from yade_side import import_yade
    from yade_side.bulk import BodySet
    O = import_yade().Omega()
    coupled = d.fe is not None
    consistent = coupled and d.coupling.consistent
    fe = d.fe(d.bridging.alpha if consistent else None) if coupled else None
    keep = d.bridging.covers if coupled else None
    ids = np.asarray(d.scene.place(keep), int)
    bar_ids = np.asarray(d.bars.place() if d.bars is not None else [], int)
    every = np.concatenate([ids, bar_ids])   # the bars' spheres are weighted and coupled too
    problems = [] if len(ids) else ["de: no sphere lies in the DE zone or the bridging domain"]
    placed = BodySet(every)
    ref_pos = placed.ref_pos
    index = np.empty(0, int)
    if coupled and len(ids):
        index = _coupled_spheres(d, fe, ref_pos, problems)
    beta_every = d.bridging.beta(ref_pos) if consistent else np.ones(len(every))
    beta = beta_every[:len(ids)]
    dt, critical = _time_step(d, fe, beta, problems)
    if problems:
        raise BuildError(problems)
    if consistent:
        from yade_side.weighting import weight_masses
        weight_masses(every, beta_every)
    links = d.scene.start(dt)
    if d.bars is not None:
        if not links:
            raise BuildError(["bars: the scene's first step makes its links, the bars need "
                              "them made in start()"])
        d.bars.start()
    if consistent and links:
        from yade_side.weighting import weight_links
        weight_links(every, beta_every)
    stepper, relaxation, notes, inside = None, None, [], False
    if coupled:
        bridge = BodySet(every[index])        # masses read once weighted
        coupling, relaxation, notes = couple(fe, d.bridging, bridge, dt, d.coupling, critical)
        stepper = CoupledStepper(O.step, bridge, fe, coupling)
        inside = d.scene.attach(stepper.couple)
    return Parts(O, ids, fe, d.bridging, beta, index[index < len(ids)], bar_ids, stepper, dt,
                 critical, relaxation, notes, inside, not links, consistent, d.bars, d.scene,
                 (placed.mass[:len(ids)], placed.inertia[:len(ids)]))


def assemble_grown(d, old):
    """The model of `d` built in the running YADE scene of the model `old`, whose DE zone
    `d`'s holds: the scene places the spheres `d` keeps that `old` did not have (after its
    own, at their reference positions: DEScene.extend), they are linked as the first step of
    a fresh scene links them (yade_side.scene.link_pairs, add_cohesive_links), every weight
    goes from old's β to the new one (masses from their unweighted values), and the FE part,
    the coupling and the stepper are made anew. Nothing else of the scene changes: the
    caller writes the added spheres' state and their links' history."""
    from yade_side.bulk import BodySet
    from yade_side.scene import add_cohesive_links, link_pairs, sort_afresh
    p = old.parts
    if d.bars is not None or p.bars is not None or d.fe is None or not len(p.ids):
        raise BuildError(["a DE zone grown in place needs a coupled model without bars"])
    consistent = d.coupling.consistent
    fe = d.fe(d.bridging.alpha if consistent else None)
    ids = np.asarray(d.scene.extend(d.bridging.covers, p.scene), int)
    sort_afresh()
    n_old = len(p.ids)
    if not np.array_equal(ids[:n_old], p.ids):
        raise BuildError(["de: the grown zone's scene does not keep the old model's spheres "
                          "first"])
    added = BodySet(ids[n_old:])
    ref_pos = np.vstack([old.spheres.ref_pos, added.ref_pos])
    unweighted = tuple(np.concatenate([a, b]) for a, b in
                       zip(p.unweighted, (added.mass, added.inertia)))
    problems = []
    index = _coupled_spheres(d, fe, ref_pos, problems)
    beta = d.bridging.beta(ref_pos) if consistent else np.ones(len(ids))
    before = np.concatenate([p.beta, np.ones(len(added))])
    dt, critical = _time_step(d, fe, beta, problems, old.fe)
    if problems:
        raise BuildError(problems)
    radius = np.concatenate([old.spheres.radius, added.radius])
    new = np.zeros(len(ids), bool)
    new[n_old:] = True
    pairs = link_pairs(ref_pos, radius, new)
    young, poisson = np.zeros(len(ids)), np.zeros(len(ids))
    for j in np.unique(pairs):
        material = p.O.bodies[int(ids[j])].material
        young[j], poisson[j] = material.young / before[j], material.poisson  # (β in young)
    if consistent:      # the old spheres' interactions and every sphere's mass and material
        from yade_side.weighting import weight_contacts, weight_links, weight_masses
        changed = np.flatnonzero(beta != before)
        weight_masses(ids[changed], beta[changed], tuple(u[changed] for u in unweighted))
        weight_links(ids[:n_old], beta[:n_old], before[:n_old])
        weight_contacts(ids[n_old:], beta[n_old:])
    made = add_cohesive_links(ids[pairs], radius[pairs],
                              np.linalg.norm(ref_pos[pairs[:, 1]] - ref_pos[pairs[:, 0]], axis=1),
                              young[pairs], poisson[pairs], 0.5 * beta[pairs].sum(axis=1))
    spheres = BodySet.joined(old.spheres, added, ref_pos)     # masses read once weighted
    bridge = spheres.subset(index, ref_pos[index])
    coupling, relaxation, notes = couple(fe, d.bridging, bridge, dt, d.coupling, critical,
                                         exact_ratio=False)
    stepper = CoupledStepper(p.O.step, bridge, fe, coupling)
    inside = d.scene.attach(stepper.couple)
    return Parts(p.O, ids, fe, d.bridging, beta, index, np.empty(0, int), stepper, dt, critical,
                 relaxation, notes, inside, False, consistent, None, d.scene, unweighted,
                 ref_pos, made, np.vstack([old.damage.links, made.ids]), spheres)


class Model:
    """A built model as the run loop sees it (orchestrator.contracts.RunModel): `step()`
    advances it one step. Cases subclass it to add their sensors (`set_sensors`) and the
    bodies whose energy counts (`energy_bodies`)."""

    def __init__(self, parts):
        from yade_side.bulk import BodySet
        from yade_side.damage import LinkDamage
        from yade_side.distributed import remote
        self.parts = p = parts
        self.O, self.fe, self.bridging, self.stepper = p.O, p.fe, p.bridging, p.stepper
        self.dt, self.critical, self.relaxation = p.dt, p.critical, p.relaxation
        self.bridge_index, self.notes = p.bridge_index, list(p.notes)
        self.spheres = BodySet(p.ids, ref_pos=p.ref_pos) if p.spheres is None else p.spheres
        self.bridge = None if p.stepper is None else p.stepper.bridge
        self.in_de_zone = (np.zeros(len(p.ids), bool) if p.bridging is None
                           else p.bridging.zone.depth(self.spheres.ref_pos) < 0)
        self.damage = LinkDamage(p.ids, exclude=p.bar_ids)
        if not p.links_pending:
            self.damage.record_initial(p.initial_links)
        self.energy_bodies = [self.spheres]
        self.sensor_names, self.sensor_positions = [], np.empty((0, 3))
        self.sensor_order = None
        self._sensor_spheres, self._sensor_nodes = BodySet([]), np.empty(0, int)
        self._seconds = {"yade": 0.0, "fe": 0.0, "coupling": 0.0}
        self._de_step = self.O.step if remote() is None else remote().step

    # --- stepping ----------------------------------------------------------------------------
    def step(self):
        p = self.parts
        t0 = perf_counter()
        if self.stepper is None or p.inside_step:
            self._de_step()
        else:
            self.stepper.de_step()
        self._seconds["yade"] += perf_counter() - t0
        if self.stepper is not None and not p.inside_step:
            self.stepper.couple()
        if p.links_pending:             # the scene's first step made its links
            if p.consistent:
                from yade_side.weighting import weight_links
                weight_links(p.ids, p.beta)
            self.damage.record_initial()
            p.links_pending = False
        if p.bars is not None:
            p.bars.step()

    def de_history(self):
        """Arrays of the DE members' own state (the bars' plasticity), for checkpoints."""
        return {} if self.parts.bars is None else self.parts.bars.history()

    def restore_de_history(self, history):
        if self.parts.bars is not None:
            self.parts.bars.restore_history(history)

    def swap_coupling(self, coupling):
        """Go on with another coupling of the same spheres (e.g. another variant); the time
        split starts again."""
        self.stepper = CoupledStepper(self.stepper.de_step, self.bridge, self.fe, coupling)
        self.parts.stepper = self.stepper
        self._seconds = {k: 0.0 for k in self._seconds}

    @property
    def seconds(self):
        """Time split of the steps so far: YADE, FE, coupling."""
        s = dict(self._seconds)
        if self.stepper is not None:
            s.update(fe=self.stepper.seconds["fe"], coupling=self.stepper.seconds["coupling"])
            if self.parts.inside_step:      # the coupling ran inside O.step
                s["yade"] -= s["fe"] + s["coupling"]
        return s

    # --- what the run loop reads ---------------------------------------------------------------
    def set_sensors(self, names, spheres, nodes, positions, order=None):
        """Sensors on spheres (indices into `spheres`), then on FE nodes, in `names` order;
        or, with `order`, sensor j is the order[j]-th of those."""
        from yade_side.bulk import BodySet
        spheres = np.asarray(spheres, int)
        self.sensor_names = list(names)
        self._sensor_spheres = BodySet(self.spheres.ids[spheres])
        self._sensor_spheres.ref_pos = self.spheres.ref_pos[spheres].copy()   # set mid-run too
        self._sensor_nodes = np.asarray(nodes, int)
        self.sensor_positions = np.asarray(positions, float).reshape(-1, 3)
        self.sensor_order = None if order is None else np.asarray(order, int)

    def sensor_displacements(self):
        """(n_sensors, 3) displacements now."""
        d = np.empty((0, 3))
        if len(self._sensor_spheres):
            self._sensor_spheres.read()
            d = self._sensor_spheres.displacement()
        if self._sensor_nodes.size:
            d = np.vstack([d, self.fe.u.reshape(-1, 3)[self._sensor_nodes]])
        return d if self.sensor_order is None else d[self.sensor_order]

    def quantities(self, last=None):
        """What the run records of its quantities of interest, or None: a case's object with
        `names`, `sample()` (their values now), `output()` (at each output frame),
        `state()` / `restore(state)` (what a checkpoint keeps, {name: array}),
        `definitions()` and `end_figures(times, values)` (what summary.json records),
        `arrays()` (what damage.npz adds); `last`: those of the model this one was grown
        from."""
        return None

    def energy(self):
        """Kinetic (spheres, FE) + CPM elastic + FE strain energy (energy_parts): with the
        consistent weighting, the coupled model's weighted energy; with the nodal one the
        bridging overlap is counted by both models (a diagnostic for blow-ups, not a
        balance)."""
        return sum(self.energy_parts().values())

    def energy_parts(self):
        """{"de_kinetic", "de_links", "fe_kinetic", "fe_strain"} (J). YADE's
        Law2_ScGeom_CpmPhys_Cpm.elasticEnergy() turns NaN once two bodies touch; it is then
        left out (0) and the kinetic energy alone is guarded."""
        from yade_side.distributed import elastic_energy
        kinetic = 0.0
        for bodies in self.energy_bodies:
            bodies.read()
            kinetic += bodies.kinetic_energy()
        elastic = elastic_energy()    # the law looked up each time: a checkpoint replaces engines
        parts = {"de_kinetic": kinetic, "de_links": elastic if np.isfinite(elastic) else 0.0}
        if self.fe is not None:
            parts.update(fe_kinetic=self.fe.kinetic_energy(), fe_strain=self.fe.strain_energy())
        return parts

    def sphere_count(self):
        return sum(len(b) for b in self.energy_bodies)

    # the spheres' volume per unit bulk volume: a broken FE cell counts as its volume × this
    # in the spheres' damaged volume (a case sets it from its packing)
    solid_fraction = 1.0

    def damaged_volume(self, sphere_damage):
        """The damaged volume of both models in one measure, m³ of spheres: a sphere's damage
        d (broken / initial links) times its volume, and, where the FE carries damage, an FE
        cell counted whole once broken as a link is (D ≥ BROKEN_OMEGA; partial damage no more
        counts there than a partly damaged link does), each weighted by its model's share of
        the band (bridging.share) and the cells by φ (solid_fraction). {"total", "de", "fe"}."""
        volume = 4.0 / 3.0 * np.pi * self.spheres.radius ** 3 * self.sphere_shares()
        de = float(np.asarray(sphere_damage) @ volume)
        fe = float(self.fe_broken() @ self.fe_cell_volumes()) if self.fe_damages else 0.0
        return {"total": de + fe, "de": de, "fe": fe}

    def fe_broken(self):
        """1 for the FE cells broken as a link is, else 0: their part of the damage measure."""
        from yade_side.scene import BROKEN_OMEGA
        return (self.fe.damage >= BROKEN_OMEGA).astype(float)

    def sphere_shares(self):
        """What each sphere's damage weighs in damaged_volume, per unit of its volume."""
        if self.fe is None:
            return np.ones(len(self.spheres))
        return 1.0 - self.bridging.share(self.spheres.ref_pos)

    @property
    def fe_damages(self):
        return self.fe is not None and self.fe.carries_damage

    def fe_cell_volumes(self):
        """What each FE cell's damage weighs in damaged_volume (m³ of spheres)."""
        return self.fe.cell_volume * self.solid_fraction * self.bridging.share(
            self.fe.cell_centres)


def couple(fe, bridging, bridge, dt, spec, critical, exact_ratio=True):
    """(coupling, r, notes): the coupling of the spheres `bridge` to `fe` as CouplingSpec
    `spec` says (its r as given, by the 1D rule, or ρ: _relaxation): α and β weigh the
    multipliers for the nodal weighting; the consistent one has them inside the partners
    already (α = β = 1 here). exact_ratio: see orchestrator.coupling.correction.Coupling."""
    relaxation, notes = _relaxation(spec, bridging, bridge, dt, critical)
    coupling = make_coupling(fe, bridging, bridge, dt, spec.variant, relaxation, spec.rotations,
                             nodal_weights=not spec.consistent, exact_ratio=exact_ratio)
    if relaxation is None:
        notes.append(f"relaxation rho: r = ρ = {coupling.relaxation:.4g}, the largest "
                     f"eigenvalue of the lumped against the full multiplier matrix: the least "
                     f"relaxation at which the {spec.variant} correction exceeds the full one in "
                     f"no constraint mode (docs/slab-bias.md)")
    return coupling, coupling.relaxation, notes


def _coupled_spheres(d, fe, ref_pos, problems):
    """Indices of the band's spheres that are coupled; each must lie in an FE cell."""
    index = bridging_spheres(d.bridging, ref_pos, d.band_tol)
    if d.uncoupled is not None:
        index = index[~d.uncoupled(ref_pos[index])]
    if index.size == 0:
        problems.append(f"coupling: no sphere lies in the bridging domain (width "
                        f"{d.bridging.width:g} m)")
        return index
    try:
        fe.check_covered(ref_pos[index])
    except ValueError as e:       # it names the first sphere outside and counts them
        problems.append(f"coupling: bridging spheres in no FE element: {e}; the mesh must "
                        f"cover the bridging domain (coupling.zone_lo, zone_hi, layers, "
                        f"element_size)")
    return index


def _time_step(d, fe, beta, problems, old_fe=None):
    """dt and the critical steps. With `old_fe` (the FE part of the model a grown zone's is
    made from: the same less cells) and dt given, the FE's is its lower bound
    (critical_dt_bound, as "fe_at_least") where that already holds dt; else its eigenvalue
    iteration starts from old_fe's dominant mode."""
    de_critical = d.scene.critical_dt(beta)
    critical, fe_critical = {"de": de_critical, "fe": None}, np.inf
    if fe is not None and old_fe is not None and d.dt is not None:
        fe_critical = fe.critical_dt_bound()
        if fe_critical >= d.dt:
            critical = {"de": de_critical, "fe_at_least": fe_critical}
    if fe is not None and "fe_at_least" not in critical:
        start = None if old_fe is None else _mode_on(old_fe, fe)
        fe_critical = fe.critical_dt() if start is None else fe.critical_dt(start)
        critical["fe"] = fe_critical
    dt, source = (d.dt, d.dt_source) if d.dt is not None else d.scene.time_step
    try:
        dt = time_step(de_critical, fe_critical, d.dt_safety, dt, source)
    except ValueError as e:
        problems.extend(str(e).split("\n"))
        dt = None
    return dt, critical


def _mode_on(old, fe):
    """The dominant mode of the FE part `old` (its critical step's) on the nodes of `fe`,
    which `old` has (a grown zone's FE: the old one less cells), 3 dofs per node; None if it
    has none or a node of `fe` is not one of old's."""
    from scipy.spatial import cKDTree
    mode = getattr(old, "dominant_mode", None)
    if mode is None or len(mode) != 3 * len(old.nodes):
        return None
    gap, at = cKDTree(old.nodes).query(fe.nodes)
    if gap.max(initial=0) > 1e-9 * np.abs(old.nodes).max():
        return None
    return mode.reshape(-1, 3)[at].ravel()


def _relaxation(spec, bridging, bridge, dt, critical):
    """r of the coupling (None: ρ, which the coupling finds), and a note of how 'auto' chose
    it: the 1D band's prediction at the case's n_b (which its geometry fixes: the spheres must
    fill the band), and where that falls short of the 1D goal, the n_b that would reach it."""
    if spec.relaxation == "rho":
        return None, []
    if spec.relaxation != "auto":
        return float(spec.relaxation), []
    layers = bridging.layers
    ratio = bridging.width / layers / (2 * bridge.radius.mean())
    safety = dt / min(v for v in critical.values() if v is not None)
    r = float(auto_relaxation(ratio, layers, spec.variant, safety, spec.weighting))
    attenuation, lf = Prediction(ratio, layers, spec.variant, safety, spec.weighting)(r)
    note = (f"relaxation auto: r = {r:.4g}, the 1D band's r with the most margin to the goal "
            f"(docs/wave1d.md) for a discretisation ratio {ratio:.3g} (element size / mean "
            f"sphere diameter), {layers} layers, {spec.variant} solver, {spec.weighting} "
            f"weighting, dt = {safety:.3g} × the critical step: predicted attenuation "
            f"{100 * attenuation:.1f} %, LF change {100 * lf:+.2f} %")
    if margin(attenuation, lf) < 1:
        need, _ = auto_layers(ratio, spec.variant, safety, spec.weighting, min_layers=layers)
        note += (f", short of the goal (>= 99 %, |LF| < 1 %): " + (
            f"{need} layers would reach it" if need else
            f"no band up to {MAX_LAYERS} layers reaches it"))
    return r, [note]
