"""Where the impact's energy goes, by kind and by place, measured alike in both models.

The input is the impactor's kinetic energy at t = 0 (no gravity, no damping, held supports:
nothing else works on the model). At an output frame it is split into
- kinetic: ½ (m v² + J ω²) of the spheres, ½ m v² of the FE nodes (half-step velocities);
- elastic: what the links and contacts hold, ½ V (σN ε + |σT|² / G0) each
  (yade_side.dissipation.LinkMeter.stored), and the FE's ½ u·f(u), split by node;
- cracking: the links' damage dissipation (yade_side.cracking, the links deleted since at
  their work to deletion) and the FE law's (dissipated_cells), the slab's cracking QoI;
- friction: the work of the links' and contacts' shear stress less the change of what their
  shear holds (the plastic slip, and the shear a released or deleted link had), and the
  normal plastic work, measured on each one at every QoI sample (LinkMeter, trapezoidal);
- coupling: what the bridging's corrections dissipate (− ExchangeMeter.net, in the band);
and the residual, the input less their sum: the error of the measure (the central-difference
integrator's half step between kinetic and stored energy, what a contact dissipates before
the meter's search finds it) and what the spheres' law creates or loses without work: the
public CPM law turns a link's shear strain with the contact each step but not its plastic
part (ConcretePM.cpp, `geom->rotate(epsT)`), so the elastic shear of a slipped link that
turns changes without work (1-2 % of the input at small scale, and 0.01 % without the
links' shear stiffness: docs/slab.md, "Where the energy goes"); in a grown zone, also what
its conversions change.

The places are those of the coupled model's zone (cases.slab.zone) in both models, by the
FE's share of the band (α without its floor) at each reference position: the DE zone (0),
the band (between), outside it (1: the FE, or the full model's spheres there), and the
impactor apart. A link is at the midpoint of its spheres (the impactor's if either is); an
FE node at its place. With the consistent weighting the band's spheres and links carry β and
its FE α: the band's figures are the coupled model's weighted energy.
"""
import numpy as np

REGIONS = ("impactor", "zone", "band", "outside")
TERMS = ("kinetic", "elastic", "cracking", "friction", "coupling")
VERSION = 1
# samples between the meter's searches for new contacts (a walk over every interaction, ~0.3
# µs each): at the next sample while searches find some (a fragment's contact lasts a few
# steps), twice as many after each that finds none, up to RELIST; and at each split
RELIST = 32


class EnergySplit:
    """The energy split of a built SlabModel (see the module). `last`: the split of the
    model this one grew from (its input and meter carry on)."""

    def __init__(self, model, last=None):
        self.m = model
        self.share = model.bridging.share
        bodies = [model.impactor, *(b for b in model.energy_bodies if b is not model.impactor)]
        ids = np.concatenate([b.ids for b in bodies])
        where = np.vstack([b.ref_pos for b in bodies])
        self._where = np.full((int(ids.max()) + 1, 3), np.nan)
        self._where[ids] = where
        self._region = np.full(int(ids.max()) + 1, -1)
        self._region[ids] = self.regions(where)
        self._region[model.impactor.ids] = 0
        self._bodies = bodies
        if last is None:
            i = model.impactor
            i.read()
            self.input = i.kinetic_energy()
            self.meter, self.wait, self.due = None, 1, 0
        else:
            self.input, self.meter, self.wait, self.due = (last.input, last.meter, last.wait,
                                                           last.due)

    def regions(self, points):
        """Index in REGIONS of each point (n, 3) of the slab: zone, band or outside."""
        a = self.share(np.asarray(points, float))
        return np.where(a <= 0, 1, np.where(a >= 1, 3, 2))

    def sample(self):
        """At a QoI sample: the meter's dissipation since the last one (it starts at the first
        sample after t = 0, once the links have had a step), and a search for new contacts
        when one is due (RELIST)."""
        from yade_side.dissipation import LinkMeter
        if self.meter is None:
            if self.m.O.iter > 0:
                self.meter = LinkMeter()
            return
        self.meter.sample()
        self.due -= 1
        if self.due <= 0:
            self.wait = 1 if self.meter.relist() else min(2 * self.wait, RELIST)
            self.due = self.wait

    def split(self, cracking):
        """{term: {region: J}} now, and "residual" (J); `cracking`: Quantities.cracking_map's
        (totals, arrays) at this time."""
        out = {t: dict.fromkeys(REGIONS, 0.0) for t in TERMS}
        out["kinetic"].update(self._kinetic())
        if self.meter is not None:
            self.meter.sample()           # from the last QoI sample to now
            self.meter.relist()           # the contacts made since the last search hold energy
            links = self._link_regions()
            alive = self.meter.alive()
            parts = self.meter.per_interaction(alive)
            for term, per_link in (("elastic", self.meter.stored(alive)),
                                   ("friction", parts["shear"] + parts["plastic"])):
                out[term].update(_by_region(links, per_link))
        totals, arrays = cracking
        out["cracking"].update(_by_region(self.regions(arrays["crack_points"]),
                                          arrays["crack_energy"]))
        out["cracking"]["impactor"] = totals["impactor_J"]
        fe = self.m.fe
        if fe is not None:
            dofs = np.repeat(self.regions(fe.nodes), 3)
            for term, per_dof in (("kinetic", fe.nodal_kinetic_energy()),
                                  ("elastic", fe.nodal_strain_energy())):
                for r, e in _by_region(dofs, per_dof).items():
                    out[term][r] += e
            out["elastic"]["outside"] += fe.members_energy()      # bars: their own part
        stepper = self.m.stepper
        if stepper is not None:
            out["coupling"]["band"] = -stepper.exchange.net
        out = {t: {r: float(v) for r, v in by.items()} for t, by in out.items()}
        out["residual"] = self.input - sum(sum(by.values()) for by in out.values())
        return out

    def _kinetic(self):
        """{region: J} of the spheres."""
        out = dict.fromkeys(REGIONS, 0.0)
        for b in self._bodies:
            b.read()
            e = 0.5 * (b.mass * np.einsum("ij,ij->i", b.vel, b.vel)
                       + b.inertia * np.einsum("ij,ij->i", b.angvel, b.angvel))
            for k, v in enumerate(np.bincount(self._region[b.ids], e, len(REGIONS))):
                out[REGIONS[k]] += v
        return out

    def _link_regions(self):
        """Index in REGIONS of each interaction the meter measures."""
        if self.meter is None:
            return np.zeros(0, int)
        keys = self.meter.keys
        if (self._region[keys[:, :2]] < 0).any():
            raise RuntimeError("an interaction of a body the model does not count: its "
                               "energy has no place")
        out = self.regions(0.5 * (self._where[keys[:, 0]] + self._where[keys[:, 1]]))
        return np.where((self._region[keys[:, 0]] == 0) | (self._region[keys[:, 1]] == 0),
                        0, out)

    def state(self):
        """What a checkpoint keeps ({name: array})."""
        out = {"input": np.array(self.input), "search": np.array([self.wait, self.due])}
        if self.meter is not None:
            out.update({f"meter_{k}": v for k, v in self.meter.state().items()})
        return out

    def restore(self, state):
        from yade_side.dissipation import LinkMeter
        self.input = float(state["input"])
        self.wait, self.due = (int(v) for v in state["search"])
        meter = {k[6:]: v for k, v in state.items() if k.startswith("meter_")}
        self.meter = LinkMeter.restored(meter) if meter else None


def row(split):
    """A split as one row: the residual, then each term's regions (TERMS × REGIONS)."""
    return [split["residual"], *(split[t][r] for t in TERMS for r in REGIONS)]


def figures(input_j, values):
    """What summary.json records of a split `row`: its version, the input, the residual and
    {term: {region: J}}."""
    values = np.asarray(values, float)
    terms = values[1:].reshape(len(TERMS), len(REGIONS))
    return {"version": VERSION, "input_J": float(input_j), "residual_J": float(values[0]),
            "terms": {t: dict(zip(REGIONS, map(float, terms[k]))) for k, t in enumerate(TERMS)}}


def _by_region(region, energy):
    """{region: the sum of `energy` over its entries}."""
    sums = np.bincount(np.asarray(region, int), np.asarray(energy, float), len(REGIONS))
    return dict(zip(REGIONS, sums))
