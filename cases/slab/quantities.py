"""What an engineer reads of a slab impact, recorded alike by the full and the coupled model
(the quantities of interest, QoIs), one definition each:

- impactor_z: the impactor's centre-of-mass z displacement since t = 0 (m, down < 0);
- impactor_vz: its centre-of-mass z velocity (m/s), the half-step velocity of the integrator;
- contact_force: the z force on the impactor averaged over the sample interval that ends at
  the sample: its momentum change over the interval divided by the interval (N, up > 0).
  No body force acts on it, so this is the slab's push; for the central-difference
  integrator the momentum change is exactly the sum of the steps' forces × dt, so the
  samples integrate to the impulse exactly, whatever the interval;
- penetration: how far the impactor's front has gone below the slab's original top face, m
  (negative: above): its descent since t = 0 less the fall before the first contact
  (impactor_gap, exact by construction: cases.slab.packings.make_packings); the front is the
  mean z of the impactor's spheres that start within one sphere diameter of its lowest
  centre (a mean, like the patches: a random packing's faces are rough by a radius, and
  the front moves apart from the centre of mass where the impactor crushes);
- reaction: the supports' summed z reaction averaged over the sample interval, the whole
  model's momentum change over the interval divided by it (N, up > 0): the supports are the
  only external force (no gravity), and the coupling's forces are internal (partition of
  unity: they cancel);
- deflection_xX: the z displacement (m) of a patch of the slab's bottom face centred at
  (X, 1.0), the span's centre line: the mean over the points of the slab's packing whose
  centre lies within PATCH_RADIUS in plan and within one sphere diameter of the bottom face
  (more than three sphere diameters across at every scale). The points are the packing's
  sphere centres, the same in both models: where the coupled model has a sphere there (DE
  zone, band) its displacement, elsewhere the FE field's at that point. Together they are
  the deflection profile along the span, which summary.json gives at the centre's peak.

The two forces are NaN at t = 0 (no interval), and the reaction at the first sample after a
grown zone's conversion (the model's momentum is carried there, not integrated).

And, at the end, damage measured alike in both models: the energy dissipated by cracking in
the slab, per cohesive link (yade_side.cracking, read at every output frame so that the links
the law deletes keep their energy) and per FE cell of an FE that cracks
(fenicsx_side.damaged: dissipated_cells), each at its place: a link at the midpoint of its
spheres' reference positions, a cell at its centre. In the coupled model's band both are
weighted (β, α) as its energy is. The impactor's own cracking is recorded apart.

At each output frame too, where the impact's energy went, by kind and by place
(cases.slab.energies): damage.npz's energy_rows, summary.json's energy_split at the end.
"""
import numpy as np

from cases.slab.scales import SLAB

VERSION = 1                 # bumped when a definition changes: compare refuses to mix them
PATCH_RADIUS = 0.1          # m, in plan
PROFILE_X = tuple(np.round(np.arange(0.25, SLAB[0], 0.25), 2))   # the span's centre line
PROFILE_Y = 0.5 * SLAB[1]
IMPACTOR = ("impactor_z", "impactor_vz", "contact_force", "penetration")
CENTRE = "deflection_x1.25"     # the patch under the impact
NAMES = IMPACTOR + ("reaction",) + tuple(f"deflection_x{x:.2f}" for x in PROFILE_X)
# the sense of each kind of QoI's peak: its largest descent (-1), rise (+1) or magnitude (0);
# the impactor's centre rises past its start when it rebounds, and the supports pull as well
# as push in the stress waves
SENSE = {"impactor_z": -1, "impactor_vz": 0, "contact_force": 1, "penetration": 1,
         "reaction": 0, "deflection": -1}


def kind(name):
    """The kind of a QoI: its name, or "deflection" for a deflection_xX."""
    return name.split("_x")[0]


def peak_index(name, values):
    """Index of the QoI `name`'s peak in `values` (its unmeasured samples never)."""
    sense = SENSE[kind(name)]
    x = np.abs(values) if sense == 0 else sense * np.asarray(values)
    return int(np.argmax(np.where(np.isfinite(x), x, -np.inf)))


# for plots: (scale, unit) of each kind of QoI
UNITS = {"impactor_z": (1e3, "mm"), "impactor_vz": (1.0, "m/s"), "contact_force": (1e-3, "kN"),
         "penetration": (1e3, "mm"), "reaction": (1e-3, "kN"), "deflection": (1e3, "mm")}


def patch_points(centres, radius):
    """{patch x: indices of the packing's spheres (centres (n, 3)) in that patch}; `radius`:
    the packing's sphere radius (the bottom layer is one diameter deep)."""
    plan = np.asarray(centres, float)
    bottom = plan[:, 2] < 2 * radius
    out = {}
    for x in PROFILE_X:
        near = np.hypot(plan[:, 0] - x, plan[:, 1] - PROFILE_Y) <= PATCH_RADIUS
        out[x] = np.flatnonzero(near & bottom)
        if out[x].size == 0:
            raise ValueError(f"no sphere of the packing in the patch at x = {x} m")
    return out


class Quantities:
    """The QoIs of a built SlabModel: `names`; `sample()` returns their values now, in
    `names` order."""
    names = NAMES

    @staticmethod
    def definitions():
        """What summary.json records of the definitions (compare refuses runs that
        differ)."""
        return {"version": VERSION, "names": list(NAMES), "patch_radius_m": PATCH_RADIUS,
                "profile_x_m": [float(x) for x in PROFILE_X], "profile_y_m": PROFILE_Y}

    def __init__(self, model, last=None):
        from yade_side.bulk import BodySet
        packs, self.m = model.scene.packs, model
        self.impactor = model.impactor
        self.impactor.read()
        self.gap = model.spec.impactor_gap
        # a run's first model is built at t = 0 (a resumed one too, before its checkpoint is
        # loaded): its front and start are read here; a grown zone's model takes them, and
        # the last sample's momenta, from `last`, the model it grew from, less the whole
        # model's momentum, which the conversion carries rather than integrates
        self.energy = _energy_split(model, None if last is None else last.energy)
        self.energy_rows = [] if last is None else last.energy_rows
        if last is None:
            z = self.impactor.pos[:, 2]
            self.front = np.flatnonzero(z < z.min() + 2 * model.spec.radius)
            self.start = (self._centre()[0][2], self._front())
            self.last = np.array([*self._momenta(), model.O.iter])
            self.cracking = None
        else:
            self.front, self.start, self.cracking = last.front, last.start, last.cracking
            self.last = last.last.copy()
            self.last[1] = np.nan
        row = {int(k): i for i, k in enumerate(model.slab_index)}
        patches = patch_points(packs.slab_centres, model.spec.radius)
        points = np.concatenate(list(patches.values()))
        rows = np.array([row.get(int(k), -1) for k in points])
        has = rows >= 0
        # the patch means: a (patches × points) averaging, split into the points with a
        # sphere and those read on the FE
        owner = np.repeat(np.arange(len(patches)), [len(p) for p in patches.values()])
        weight = 1.0 / np.bincount(owner)[owner]
        self.spheres = BodySet(model.spheres.ids[rows[has]],
                               ref_pos=packs.slab_centres[points[has]])
        self.sphere_mean = _averaging(owner[has], weight[has], len(patches))
        self.fe_mean = None
        if not has.all():
            k = model.fe.point_operators(packs.slab_centres[points[~has]])[0][2::3]
            self.fe_mean = _averaging(owner[~has], weight[~has], len(patches)) @ k

    def _front(self):
        return float(np.mean(self.impactor.pos[self.front, 2]))

    def _centre(self):
        i = self.impactor
        mass = i.mass.sum()
        return i.mass @ i.pos / mass, i.mass @ i.vel / mass

    def _momenta(self):
        """(impactor's, whole model's) z momentum now."""
        total = 0.0
        for bodies in self.m.energy_bodies:
            bodies.read()
            total += bodies.mass @ bodies.vel[:, 2]
        fe = self.m.fe
        if fe is not None:
            total += (fe.mass * fe.v)[2::3].sum()
        i = self.impactor
        return i.mass @ i.vel[:, 2], total

    def state(self):
        """What a checkpoint keeps: the last sample's momenta and step, the links' cracking
        energy at the last output ({name: array})."""
        out = {"last": self.last.copy()}
        if self.cracking is not None:
            out.update({f"cracking_{k}": v for k, v in self.cracking._asdict().items()})
        if self.energy is not None:
            out.update({f"energy_{k}": v for k, v in self.energy.state().items()})
            out["energy_rows"] = np.array(self.energy_rows, float)
        return out

    def restore(self, state):
        from yade_side.cracking import LinkCracking
        self.last = np.array(state["last"], float)
        if "energy_input" not in state:       # a checkpoint of a run made before the split
            self.energy = None
        elif self.energy is not None:
            self.energy.restore({k[7:]: v for k, v in state.items()
                                 if k.startswith("energy_") and k != "energy_rows"})
            self.energy_rows = [list(r) for r in np.asarray(state["energy_rows"], float)]
        if "cracking_ids" in state:
            self.cracking = LinkCracking(*(np.asarray(state[f"cracking_{k}"])
                                           for k in LinkCracking._fields))

    def output(self):
        """At an output frame: the links' cracking energy, those deleted since the last
        frame kept at their work to deletion (a scene split over MPI ranks: not measured)."""
        from yade_side.cracking import link_cracking_energy
        from yade_side.distributed import remote
        if remote() is None:
            self.cracking = link_cracking_energy(self.cracking)
        if self.energy is not None:
            from cases.slab.energies import row
            self.energy_rows.append([self.m.O.iter * self.m.dt,
                                     *row(self.energy.split(self.cracking_map()))])

    def cracking_map(self):
        """({"slab_J", "slab_links_J", "slab_fe_J", "impactor_J"}, {"crack_points" (n, 3),
        "crack_energy" (n,) J, "crack_fe" (n,) bool: a cell}): the slab's links, then the FE
        cells; None without a measure (MPI)."""
        if self.cracking is None:
            return None
        m, c = self.m, self.cracking
        # in the order of their ids: the scene's own order is the order links were made in,
        # which a checkpoint's reload changes
        c = type(c)(*(a[np.lexsort(c.ids.T[::-1])] for a in c))
        ids, where = self.m.spheres.ids, self.m.spheres.ref_pos
        order = np.argsort(ids)
        at = np.searchsorted(ids[order], c.ids).clip(0, len(ids) - 1)
        slab = (ids[order][at] == c.ids).all(axis=1)
        points = 0.5 * where[order][at[slab]].sum(axis=1)
        energy, fe = c.energy[slab], np.zeros(np.count_nonzero(slab), bool)
        links = float(energy.sum())
        fe_energy = 0.0
        if m.fe is not None and m.fe.carries_damage:
            cells = m.fe.dissipated_cells
            fe_energy = float(cells.sum())
            points = np.vstack([points, m.fe.cell_centres])
            energy = np.concatenate([energy, cells])
            fe = np.concatenate([fe, np.ones(len(cells), bool)])
        totals = {"slab_J": links + fe_energy, "slab_links_J": links, "slab_fe_J": fe_energy,
                  "impactor_J": float(c.energy[np.isin(c.ids, m.impactor_ids).all(axis=1)]
                                      .sum())}
        return totals, {"crack_points": points, "crack_energy": energy, "crack_fe": fe}

    def sample(self):
        if self.energy is not None:
            self.energy.sample()
        now = np.array([*self._momenta(), self.m.O.iter])   # reads the impactor too
        interval = (now[2] - self.last[2]) * self.m.dt
        rates = (now[:2] - self.last[:2]) / interval if interval > 0 else [np.nan, np.nan]
        self.last = now
        x, v = self._centre()
        self.spheres.read()
        deflection = self.sphere_mean @ self.spheres.displacement()[:, 2]
        if self.fe_mean is not None:
            deflection = deflection + self.fe_mean @ self.m.fe.u
        centre0, front0 = self.start
        return np.concatenate([[x[2] - centre0, v[2], rates[0],
                                front0 - self._front() - self.gap, rates[1]], deflection])

    def end_figures(self, times, values):
        """What summary.json records at the end: the impactor's residual velocity (m/s, its
        centre of mass's z velocity at the last sample), whether it perforated the slab (its
        front below the slab's original bottom face: penetration past the thickness), each
        QoI's peak (peak_index: its value, signed) and its time, and the cracking energy
        (cracking_map's totals, None where not measured)."""
        from cases.slab.energies import figures
        cracking = self.cracking_map()
        return {**peak_figures(times, values),
                "cracking_energy": None if cracking is None else cracking[0],
                "energy_split": (figures(self.energy.input, self.energy_rows[-1][1:])
                                 if self.energy is not None and self.energy_rows else None)}

    def arrays(self):
        """What damage.npz adds: cracking_map's arrays and the energy split's rows at the
        output frames ("energy_rows": time, then energies.row; none where not measured)."""
        cracking = self.cracking_map()
        out = {} if cracking is None else dict(cracking[1])
        if self.energy is not None and self.energy_rows:
            out["energy_rows"] = np.array(self.energy_rows, float)
        return out


def peak_figures(times, values):
    """The residual velocity, perforation and peaks of Quantities.end_figures, and the
    deflection profile along the span's centre line at the centre's peak."""
    values = np.asarray(values, float)
    last = dict(zip(NAMES, values[-1]))
    peaks = {}
    for name, column in zip(NAMES, values.T):
        k = peak_index(name, column)
        peaks[name] = {"peak": float(column[k]), "time_s": float(times[k])}
    k = peak_index(CENTRE, values[:, NAMES.index(CENTRE)])
    profile = [NAMES.index(f"deflection_x{x:.2f}") for x in PROFILE_X]
    return {"residual_velocity_m_s": float(last["impactor_vz"]),
            "perforated": bool(last["penetration"] > SLAB[2]), "peaks": peaks,
            "profile_at_peak": {"time_s": float(times[k]), "x_m": [float(x) for x in PROFILE_X],
                                "deflection_m": values[k, profile].tolist()}}


STOPPED = 0.01       # × the impact speed: an impactor this slow (or rising) has stopped
REBOUND = 0.5        # the slab has rebounded once its centre has risen by this × its descent


def event_ends(times, values):
    """When the impact is over in the run of QoI `values` (n_times, NAMES) at `times`:
    {"impactor_s", "slab_s"}, when the impactor has stopped (its centre's descent slower
    than STOPPED × the impact speed), rebounded or perforated (penetration past the slab's
    thickness); and when, after that, the slab's centre (CENTRE) has passed its
    deepest point so far and risen back by REBOUND × that depth. None where the record ends
    before (a slab broken under the impact, whose centre's spheres fly off, never rises)."""
    q = {name: np.asarray(values, float)[:, k] for k, name in enumerate(NAMES)}
    speed = abs(q["impactor_vz"][0])
    over = (q["impactor_vz"] >= -STOPPED * speed) | (q["penetration"] > SLAB[2])
    if not over.any():
        return {"impactor_s": None, "slab_s": None}
    first = int(np.argmax(over))
    d = q[CENTRE]
    deepest = np.minimum.accumulate(d)
    risen = ((deepest < 0) & (d - deepest >= -REBOUND * deepest))[first:]
    return {"impactor_s": float(times[first]),
            "slab_s": float(times[first + int(np.argmax(risen))]) if risen.any() else None}


def _energy_split(model, last):
    """The model's EnergySplit (cases.slab.energies), or None where it is not measured: a
    run without it (spec.energy_split), or one where split_unmeasured says why."""
    from cases.slab.energies import EnergySplit
    if not model.spec.energy_split or split_unmeasured(model):
        return None
    return EnergySplit(model, last)


def split_unmeasured(model):
    """Why the energy split asked of `model` cannot be measured (a scene split over MPI
    ranks, an FE over several: the meter reads one process's memory), else None."""
    from yade_side.distributed import remote
    if remote() is not None:
        return "its YADE scene is split over MPI ranks"
    if model.fe is not None and model.fe.comm.size > 1:
        return "its FE is split over MPI ranks"
    return None


def _averaging(patch, weight, n):
    """(n × points) sparse matrix: row p the mean over its points."""
    import scipy.sparse as sp
    return sp.csr_matrix((weight, (patch, np.arange(len(patch)))), shape=(n, len(patch)))
