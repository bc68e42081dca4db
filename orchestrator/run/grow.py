"""A DE zone that grows during the run (`--zone grow`): the automatic zone's indicators
(orchestrator.run.autozone) trip as there, and instead of starting again from t = 0 the run
goes on from the same step in the model of the grown zone, built in the same YADE scene
through the one builder (orchestrator.builder.assemble_grown) and given the old model's state
(docs/auto-zone.md):
- the DE's bodies and interactions stay as they are (links, their history, contacts);
- bodies new to the DE (the converted FE cells and the new band), added to the scene: the
  FE field at their centre, position ref + k u, velocity k v, rotation and spin h u, h v
  (½ curl), and outside the new band the gap between the old DE's edge and that field,
  carried on harmonically (continued_gaps); their links take the reference lengths of a
  fresh scene stretched so that each one's normal strain is the FE field's (the gap a
  stress-free offset: fe_stretch), and CPM damages them from that strain at their first
  step (along each link's own direction); a cell's compression damage becomes their normal
  plastic strain (link_compaction); with `shear` they take the FE's affine shear strain
  too (by default not: it adds 2-3 × the energy the cells had, as a random packing's links
  under an affine shear do; docs/auto-zone.md);
- FE nodes and cells that stay FE (matched by coordinates): u, v, t and the damage history;
- the coupling: the band spheres' accumulated rotations (the old band's kept, the new ones'
  h u), the energy meter.
The new model's FE part, stepper and multiplier operators are the builder's: the band's
factorisation is made once per conversion. YADE's own step counter goes on (what counts the
run's steps is the run loop's; periodic engines keep the run's phase).
"""
import logging
from dataclasses import dataclass
from time import perf_counter

import numpy as np
from scipy.spatial import cKDTree

from orchestrator.run.autozone import Tripped, Watch
from orchestrator.run.restart import add_splits

run_log = logging.getLogger("orchestrator.run")
GROWTH_STATE_VERSION = 2    # of what checkpoint_state writes (2: bodies in the growth's order)


class ZoneLimit(Exception):
    """The zone cannot grow as the trip `tripped` asks, because of `reason`: `reached` is
    "cells" (its limit) or "cost" (the budget)."""

    def __init__(self, reason, reached, tripped):
        super().__init__(f"{reason} ({tripped})")
        self.reason, self.reached, self.tripped = reason, reached, tripped


def match(old, new, tol):
    """For each point of `new`, the index of the point of `old` within `tol` of it, or -1."""
    if len(old) == 0:
        return np.full(len(new), -1)
    dist, index = cKDTree(old).query(new, distance_upper_bound=tol)
    return np.where(np.isfinite(dist), index, -1)


def carry(old, new, tol, shear=False):
    """Put `new`, the model of a grown zone built in the running scene of `old`
    (orchestrator.builder.assemble_grown), in old's state: the spheres it added take old's FE
    field and the gap carried on (continued_gaps), their links the field's normal strain
    (fe_stretch), the FE's compaction (and with `shear` its affine shear strain); the FE
    nodes and cells that stay FE, the band's accumulated rotations and the exchange's state
    are old's. Returns the counts of what was carried and the links' largest stretch of
    their reference length (fe_stretch)."""
    from yade_side.bulk import rotation_quaternion
    from yade_side.memory import WIDTH, history_offset
    from yade_side.transfer import EPS_N_PL, EPS_T, SAMPLE, lever_arms_are_radii
    old_fe, fe, s = old.fe, new.fe, new.spheres
    ref, radius = s.ref_pos, s.radius
    added = np.arange(len(old.spheres), len(s))
    state = s.read()
    k, h = old_fe.point_operators(ref[added])
    state[added, 0:3] = ref[added] + (k @ old_fe.u).reshape(-1, 3)
    state[added, 3:6] = (k @ old_fe.v).reshape(-1, 3)
    state[added, 6:9] = (h @ old_fe.v).reshape(-1, 3)
    state[added, 9:13] = rotation_quaternion((h @ old_fe.u).reshape(-1, 3))
    band = match(new.stepper.bridge.ref_pos, ref[added], tol) >= 0
    gaps = continued_gaps(ref, radius, added[~band], added[band],
                          lambda j: (state[j, 0:3] - ref[j], state[j, 3:6]),
                          lambda j: old_fe.covers(ref[j]),
                          lambda j: _field(old_fe, ref[j]))
    on_field = state[:, 0:3].copy()            # the FE field's positions, before the gaps
    state[added[~band], 0:6] += gaps
    s.write()
    made, stretch = new.parts.new_links, 0.0
    if made:
        row = np.full(s.ids.max() + 1, -1)
        row[s.ids] = np.arange(len(s))
        ends = row[made.ids]
        kept = np.unique(ends[ends < len(old.spheres)])      # the old DE's, on the old FE
        kept = kept[old_fe.covers(ref[kept])]
        on_field[kept] = ref[kept] + _field(old_fe, ref[kept])[0]
        stretch = fe_stretch(made.phys, ends, on_field, state[:, 0:3],
                             np.isin(ends, kept) | (ends >= len(old.spheres)))
    if made and (old_fe.carries_damage or shear):
        history = history_offset(made.phys, SAMPLE), WIDTH
        values = made.fields.read_block(*history)
        axis = ref[ends[:, 1]] - ref[ends[:, 0]]
        length = np.linalg.norm(axis, axis=1)
        normal = axis / length[:, None]
        values[:, EPS_N_PL] = link_compaction(old_fe, 0.5 * ref[ends].sum(axis=1), normal)
        if shear:
            at = ref[np.where(ends[:, 0] >= len(old.spheres), ends[:, 0], ends[:, 1])]
            lever = radius[ends].sum(axis=1) if lever_arms_are_radii() else length
            values[:, EPS_T] = affine_shear_strain(old_fe.gradient_at(at), normal,
                                                   lever / length)
        made.fields.write_block(*history, values)
    nodes = match(old_fe.nodes, fe.nodes, tol)
    cells = match(_centres(old_fe), _centres(fe), tol)
    if (nodes < 0).any() or (cells < 0).any():
        raise RuntimeError("the grown zone's FE part has nodes or cells the old one did not")
    fe.take_state(old_fe, nodes, cells)
    old_bridge, bridge = old.stepper.bridge, new.stepper.bridge
    kept = match(old_bridge.ref_pos, bridge.ref_pos, tol)
    rotation = np.empty((len(bridge), 3))
    rotation[kept >= 0] = old_bridge.rotation[kept[kept >= 0]]
    if (kept < 0).any():
        h = old_fe.point_operators(bridge.ref_pos[kept < 0])[1]
        rotation[kept < 0] = (h @ old_fe.u).reshape(-1, 3)
    bridge.rotation[:] = rotation
    bridge.rotation_pred[:] = rotation
    bridge.read()
    new.stepper.exchange.to_fe = old.stepper.exchange.to_fe
    new.stepper.exchange.net = old.stepper.exchange.net
    return {"bodies_kept": len(old.spheres), "bodies_added": len(added),
            "links_new": len(made), "stretch": stretch}


def fe_stretch(phys, ends, on_field, now, known):
    """Each new link's normal strain made the FE field's stretch of it, |Δ on_field| / L − 1
    (L its reference length), whatever the gap between its spheres' positions `now` and the
    field: its reference length × |Δ now| / |Δ on_field| (refPD, kn and ks with it, as the
    law sets them from the reference length). The gap carried on (continued_gaps) keeps the
    motion continuous at the old DE's edge; as a stress-free offset it adds no strain energy.
    phys: the links' CpmPhys; ends (m, 2): rows of `now` and `on_field` ((n, 3) positions);
    known: (m, 2) mask of the ends whose field position is known (a link with another end is
    left).
    Returns the largest |scale − 1|."""
    both = known.all(axis=1)
    d_field = np.linalg.norm(on_field[ends[:, 1]] - on_field[ends[:, 0]], axis=1)
    d_now = np.linalg.norm(now[ends[:, 1]] - now[ends[:, 0]], axis=1)
    scale = np.where(both, d_now / np.where(both, d_field, 1.0), 1.0)
    for p, c in zip(phys, scale.tolist()):
        if c != 1.0:
            radii = p.refPD + p.refLength
            p.refLength *= c
            p.refPD = radii - p.refLength
            p.kn, p.ks = p.kn / c, p.ks / c
    return float(np.abs(scale - 1).max(initial=0.0))


def continued_gaps(ref, radius, free, zero, old_motion, covered, fe_motion):
    """The gaps between the DE's own motion and the FE's field at the old DE's edge, carried
    on into the new DE bodies `free`: harmonic over the link graph (bodies closer than
    INTERACTION_RADIUS × their radii), equal to the gap (u, v) − FE field (u, v) at every
    old body linked to a new one that the FE covers (old_motion(j), fe_motion(j): (n, 3)
    displacements and velocities; covered(j): mask), 0 at the bodies `zero` (the new band,
    which follows the FE). Returns (len(free), 6): what to add to the new bodies' FE-field
    displacement and velocity.

    Bodies new to the DE take the FE's field, but the old DE's edge is not on it (the
    coupling holds the band to the FE weakly, the impact compresses it locally): a new link
    between the two would take that gap as its strain, in one link's length; continued
    harmonically, it spreads over the converted cells (docs/auto-zone.md)."""
    from scipy.sparse import coo_matrix, diags
    from scipy.sparse.linalg import spsolve
    from yade_side.scene import INTERACTION_RADIUS
    if len(free) == 0:
        return np.zeros((0, 6))
    tree = cKDTree(ref)
    near = tree.query_ball_point(ref[free], INTERACTION_RADIUS * 2 * radius.max())
    a = np.repeat(free, [len(n) for n in near])
    b = np.concatenate([np.asarray(n, int) for n in near])
    linked = (a != b) & (np.linalg.norm(ref[a] - ref[b], axis=1)
                         < INTERACTION_RADIUS * (radius[a] + radius[b]))
    a, b = a[linked], b[linked]
    is_free = np.zeros(len(ref), bool)
    is_free[free] = True
    is_new = is_free.copy()
    is_new[zero] = True
    old = np.unique(b[~is_new[b]])
    old = old[covered(old)] if len(old) else old
    known = np.zeros((len(ref), 6))
    if len(old):
        u, v = old_motion(old)
        fu, fv = fe_motion(old)
        known[old] = np.hstack([u - fu, v - fv])
    keep = is_new[b] | np.isin(b, old)
    a, b = a[keep], b[keep]
    row = np.full(len(ref), -1)
    row[free] = np.arange(len(free))
    inner = is_free[b]
    n = len(free)
    L = coo_matrix((-np.ones(np.count_nonzero(inner)), (row[a[inner]], row[b[inner]])),
                   shape=(n, n)).tocsr()
    degree = np.bincount(row[a], minlength=n).astype(float)
    # a cluster with no known body takes 0 (the diagonal's 1e-12 more), not a singular solve
    L = L + diags(degree * (1 + 1e-12))
    rhs = np.zeros((n, 6))
    np.add.at(rhs, row[a[~inner]], known[b[~inner]])
    return spsolve(L.tocsc(), rhs).reshape(n, 6)


def _field(fe, points):
    """The FE's displacement and velocity at `points`, (n, 3) each."""
    k = fe.point_operators(points)[0]
    return (k @ fe.u).reshape(-1, 3), (k @ fe.v).reshape(-1, 3)


def link_compaction(fe, points, normal):
    """CPM's normal plastic strain epsNPl of links of normal n at `points` of the FE `fe`:
    n·ε_p·n, ε_p the compaction of the cell there (damage_law.ConcreteDamage.compaction); 0
    in an FE without damage, and outside its cells. A CPM link is not damaged in
    compression: fresh links under a crushed cell's strain would hold the cell's undamaged
    stress; with its compaction as their plastic strain they carry the cell's compressive
    stress, and unload as the spheres' own compression test does (docs/auto-zone.md)."""
    if not fe.carries_damage or len(points) == 0:
        return np.zeros(len(points))
    return np.einsum("pab,pa,pb->p", fe.compaction_at(points), normal, normal)


def affine_shear_strain(G, normal, lever_ratio):
    """CPM's shear strain epsT of links of normal n (from id1 to id2) whose spheres moved with
    the displacement gradient G and turned with it (W = skew G, ½ curl u): the tangential part
    of G n − r W n, r = lever arms / link length (1 with the contact point's arms: a rigid
    rotation then strains no link; (r₁ + r₂)/L with YADE's default radii arms)."""
    W = 0.5 * (G - G.transpose(0, 2, 1))
    t = (np.einsum("pab,pb->pa", G, normal)
         - np.asarray(lever_ratio)[:, None] * np.einsum("pab,pb->pa", W, normal))
    return t - np.einsum("pa,pa->p", t, normal)[:, None] * normal


def strain_energy_ratio(before, after):
    """The strain energy the DE's links gained at a conversion over the one the FE lost (the
    models' energy_parts before and after): 1 when the spheres stand for the cells they
    replace with the cells' stiffness; None when the FE lost none or the links' energy is
    unreadable (energy_parts gives 0 then)."""
    lost = before["fe_strain"] - after["fe_strain"]
    if not lost > 0 or not (before["de_links"] and after["de_links"]):
        return None
    return (after["de_links"] - before["de_links"]) / lost


def _centres(fe):
    return fe.nodes[fe.cell_nodes].mean(axis=1)


class GrowingModel:
    """A coupled model whose DE zone grows during the run (orchestrator.contracts.RunModel:
    the run loop steps it as any model). build(mask, grown_from=None, earlier=()) -> Model:
    the model of a zone (a mask of `grid`), every one with the run's time step, built afresh
    (its spheres placed in the order the zones `earlier` and then its own add them) or in the
    running scene of the model `grown_from`; the zone grows at each trip over the
    flagged cells and `levels.margin` more, inside `limit`; budget(segments, n) says why
    growing at step n cannot pay (None if it can; segments: (spheres, steps) of each zone
    run so far). Bodies, nodes and cells of two models match within `tol` (m); `shear`:
    see carry; `last_step`: the run's last step, where a trip converts nothing (no step
    follows; the post-run check reads the same cells and warns). Listeners in `on_grow` are
    told (old, new, k) after the k-th conversion. Reads of attributes go to the current
    model. Checkpoints: checkpoint_state() is what the growth adds to the current model's
    state (orchestrator.run.restart); `resumed` (a ResumedGrowth read back from one) builds
    the model of its last zone and takes its growth."""

    def __init__(self, build, grid, zone, limit, tensile_strength, levels, tol, budget=None,
                 log=print, shear=False, resumed=None, last_step=None):
        from yade_side.memory import VERIFIED, verified, yade_version
        if not verified():
            raise ValueError(f"a zone that grows during the run writes its new links in YADE's "
                             f"memory, whose layout was verified on YADE {', '.join(VERIFIED)} "
                             f"only, not on this YADE {yade_version()}")
        t0 = perf_counter()
        self.__dict__.update(build=build, cell_grid=grid, limit=limit, ft=tensile_strength,
                             levels=levels, tol=tol, budget=budget, log=log, shear=shear,
                             last_step=last_step)
        self.zone = zone.copy()
        self.zones = [self.zone.copy()]
        if resumed is not None:         # a checkpoint's growth (checkpoint_state): its zone
            self.zones = [z.copy() for z in resumed.zones]
            self.zone = self.zones[-1].copy()
        self.current = build(self.zone, earlier=self.zones[:-1])
        if self.current.parts.inside_step:
            raise ValueError("a zone that grows during the run needs the coupling outside "
                             "YADE's step (its forces are read at a step of zero length)")
        self.watch = Watch(self.current, grid, tensile_strength, levels)
        self.conversions, self.on_grow = [], []
        self.segments = []              # (spheres, steps) of each zone run
        self._earlier = {}              # time split of the earlier models
        self.peaks = {"stress": 0.0, "omega": 0.0, "damage": 0.0, "band": 0.0}
        self._bind_sensors = None       # the first model's sensors, at its first growth
        if resumed is not None:
            self._restore(resumed)
        self.build_s = perf_counter() - t0

    def __getattr__(self, name):
        current = self.__dict__.get("current")
        if current is None:
            raise AttributeError(name)
        return getattr(current, name)

    def step(self):
        try:
            self.current.step()
        except Tripped as t:
            if t.step == self.last_step:
                run_log.info("%s at the run's last step: nothing converted", t)
            else:
                self.grow(t)

    def _segment(self, n):
        """(spheres, steps) of the current zone's run up to step n."""
        return self.current.sphere_count(), n - sum(steps for _, steps in self.segments)

    @property
    def seconds(self):
        return add_splits(self._earlier, self.current.seconds)

    @property
    def steps(self):
        return self.watch.steps

    def grow(self, tripped):
        """Convert the cells `tripped` flags, and `levels.margin` more, and go on in the model
        of the grown zone; ZoneLimit if the zone cannot grow so."""
        from yade_side.scene import keep_engine_phase, settle_forces
        from yade_side.transfer import link_energies
        t0 = perf_counter()
        grid, old, n = self.cell_grid, self.current, self.watch.steps
        grown = tripped.grown(self.zone, grid, self.levels.margin, self.limit)
        if grown is None:
            raise ZoneLimit(f"the DE zone would pass its limit ({tripped.beyond(self.limit)})",
                            "cells", tripped)
        segment = self._segment(n)
        why = None if self.budget is None else self.budget(self.segments + [segment], n)
        if why:
            raise ZoneLimit(why, "cost", tripped)
        self._record_peaks()
        settle_forces()
        before = old.energy_parts()
        if self._bind_sensors is None:
            self._bind_sensors = _sensor_binding(old)
        self.segments.append(segment)
        self._earlier = add_splits(self._earlier, old.seconds)
        t_build = perf_counter()
        new = self.build(grown, grown_from=old)
        t_build = perf_counter() - t_build
        t_carry = perf_counter()
        carried = carry(old, new, self.tol, self.shear)
        t_carry = perf_counter() - t_carry
        self._bind_sensors(new)
        settle_forces()
        keep_engine_phase(n)
        after = new.energy_parts()
        made = new.parts.new_links
        seam = np.isin(made.ids, old.spheres.ids).any(axis=1)
        normal, shear = link_energies(made.interactions, made.fields)
        total = lambda values: sum(values.tolist(), 0.0)
        energy_before, energy_after = sum(before.values()), sum(after.values())
        self.watch = Watch(new, grid, self.ft, self.levels)
        self.watch.steps = n
        self.current, self.zone = new, grown
        self.zones.append(grown.copy())
        band = grid.dilate(self.zones[-2], old.bridging.layers) & ~self.zones[-2]
        self.conversions.append({
            "step": n, "indicator": tripped.indicator,
            "cells": np.argwhere(grown & ~self.zones[-2]).tolist(), "zone_cells": int(grown.sum()),
            "tripped_cells": np.argwhere(tripped.cells).tolist(),
            "tripped_in_band": int(np.count_nonzero(tripped.cells & band)),
            "spheres_added": carried["bodies_added"], "spheres": int(new.sphere_count()),
            "energy_before": energy_before, "energy_after": energy_after,
            "energy_parts_before": before, "energy_parts_after": after,
            "new_links_energy": {"normal": total(normal), "shear": total(shear),
                                 "seam": {"links": int(seam.sum()), "of": len(made),
                                          "normal": total(normal[seam]),
                                          "shear": total(shear[seam])}},
            "strain_energy_ratio": strain_energy_ratio(before, after),
            "carried": carried, "wall_s": perf_counter() - t0, "build_s": t_build,
            "carry_s": t_carry})
        line = (f"zone grown at step {n} ({tripped.indicator}): {int(grown.sum())} cells, "
                f"{new.sphere_count()} spheres (+{carried['bodies_added']}); energy "
                f"{energy_before:.6g} J → {energy_after:.6g} J")
        run_log.info("%s; %s; energy parts %s → %s", line, carried, before, after)
        self.log(line)
        for listener in self.on_grow:
            listener(old, new, len(self.conversions))

    def _record_peaks(self):
        w = self.watch
        for key, value in (("stress", w.peak_stress), ("omega", w.peak_omega),
                           ("damage", w.peak_damage), ("band", w.peak_band)):
            self.peaks[key] = max(self.peaks[key], value)

    # --- checkpoints (orchestrator.run.restart saves the current model's state as any
    # model's: scene, FE, coupling; this is what the growth adds) ------------------------------
    def checkpoint_state(self):
        """What a checkpoint keeps of the growth: (a JSON-able dict, {name: array}): the zone
        of every segment (the last one is the current model's), the conversions, the zone
        segments, the indicators' peaks and step count, the time step every zone's model
        takes, and the first model's sensors (once bound elsewhere). The earlier models'
        time split is not kept: the run loop's record holds it."""
        w = self.watch
        info = {"version": GROWTH_STATE_VERSION, "dt": float(self.current.dt),
                "zone_cells": int(self.zone.sum()), "conversions": self.conversions,
                "segments": [[int(a), int(b)] for a, b in self.segments],
                "peaks": dict(self.peaks),
                "watch": {"steps": int(w.steps), "seconds": float(w.seconds),
                          "peak_stress": float(w.peak_stress),
                          "peak_omega": float(w.peak_omega),
                          "peak_damage": float(w.peak_damage),
                          "peak_band": float(w.peak_band)},
                "sensors": None}
        arrays = {"zones": np.array(self.zones, dtype=bool)}
        if self._bind_sensors is not None:
            b = self._bind_sensors
            info["sensors"] = {"names": list(b.names)}
            arrays.update(sensor_positions=b.positions, sensor_sphere_ref=b.sphere_ref,
                          sensor_node_pos=b.node_pos)
        return info, arrays

    def _restore(self, resumed):
        """Take the growth of a checkpoint (ResumedGrowth); the current model is the one of
        its last zone, built; the scene, FE and coupling states are the run loop's to load."""
        info, w = resumed.info, resumed.info["watch"]
        self.conversions = list(info["conversions"])
        self.segments = [(int(a), int(b)) for a, b in info["segments"]]
        self.peaks.update({k: float(v) for k, v in info["peaks"].items()})
        self.watch.steps, self.watch.seconds = int(w["steps"]), float(w["seconds"])
        self.watch.peak_stress, self.watch.peak_omega, self.watch.peak_damage = (
            float(w["peak_stress"]), float(w["peak_omega"]), float(w["peak_damage"]))
        self.watch.peak_band = float(w.get("peak_band", 0.0))   # absent: written before it
        if info["sensors"] is not None:
            a = resumed.arrays
            self._bind_sensors = SensorBinding(list(info["sensors"]["names"]),
                                               a["sensor_positions"], a["sensor_sphere_ref"],
                                               a["sensor_node_pos"])
            self._bind_sensors(self.current)

    def record(self, steps):
        """What summary.json keeps of the growth."""
        self._record_peaks()
        segments = self.segments + [self._segment(steps)]
        return {"zone_conversions": self.conversions,
                "zone_final": {"cells": np.argwhere(self.zone).tolist(),
                               "n_cells": int(self.zone.sum())},
                "zone_sphere_steps": int(sum(a * b for a, b in segments)),
                "zone_energy_added": float(sum(c["energy_after"] - c["energy_before"]
                                               for c in self.conversions)),
                "zone_segments": [{"spheres": int(a), "steps": int(b)} for a, b in segments],
                "zone_peaks": dict(self.peaks)}


@dataclass
class ResumedGrowth:
    """A checkpoint's growth state (GrowingModel.checkpoint_state, read back)."""
    info: dict
    arrays: dict

    @property
    def zones(self):
        return list(self.arrays["zones"])


@dataclass
class SensorBinding:
    """The sensors of a run's first model, put on another model (a grown zone's): at the same
    points of the body, read from the same sphere, or for an FE node that a grown zone has
    taken, from the sphere nearest its position (as the full model reads it)."""
    names: list
    positions: np.ndarray      # (n_sensors, 3): where the sensors are
    sphere_ref: np.ndarray     # reference positions of the first model's sensor spheres
    node_pos: np.ndarray       # positions of its sensor FE nodes

    def __call__(self, model):
        n_spheres, node_pos = len(self.sphere_ref), self.node_pos
        ref = model.spheres.ref_pos
        nearest = lambda points: [int(np.argmin(np.linalg.norm(ref - p, axis=1)))
                                  for p in points]
        at = match(model.fe.nodes, node_pos, 1e-9 * (1 + np.abs(node_pos).max(initial=0)))
        # sensor j of `first` is the order[j]-th of the spheres, then the nodes, bound here
        taken = np.flatnonzero(at < 0)
        bound = list(range(n_spheres)) + [n_spheres + j for j in taken] + \
            [n_spheres + j for j in np.flatnonzero(at >= 0)]
        model.set_sensors(self.names, nearest(self.sphere_ref) + nearest(node_pos[taken]),
                          [int(i) for i in at if i >= 0], self.positions, np.argsort(bound))


def _sensor_binding(first):
    """The SensorBinding of the model `first`'s sensors."""
    if first.sensor_order is not None:
        raise ValueError("the first model's sensors must be in set_sensors' order")
    n_spheres = len(first._sensor_spheres)
    return SensorBinding(
        list(first.sensor_names), first.sensor_positions.copy(),
        first._sensor_spheres.ref_pos.copy() if n_spheres else np.empty((0, 3)),
        first.fe.nodes[first._sensor_nodes] if first._sensor_nodes.size else np.empty((0, 3)))
