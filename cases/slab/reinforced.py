"""The reinforced slab: its bars in both models (docs/reinforcement.md).

`--reinforced` (or a case file's `[[reinforcement]]` layers) gives the slab bars:
- full model: DE steel chains through the whole slab (yade_side.bars), bonded to the concrete;
- coupled model: each bar cut at the DE zone (cases.bar_split): chains where the model has
  spheres (DE zone and band), embedded trusses (fenicsx_side.bars) where it has FE (band and
  beyond). In the band both carry the bar, weighted as the concrete there: the consistent
  weighting puts α in the trusses' stiffness and mass and β in the chains' masses and links
  (orchestrator.builder weights them with the concrete spheres, whose links include the
  bonds); the nodal weighting leaves both unweighted, as the concrete. The chain spheres in
  the band are coupled like the concrete spheres (the method constrains every DE particle of
  the band to the FE field, and the FE bar follows that field: the two bars hand their force
  over in the band as the concrete does).

The default mesh (DEFAULT_MESH): 12 mm bars at 150 mm both ways at both faces, 30 mm concrete
cover, B500 steel (E 200 GPa, fy 500 MPa, 7,850 kg/m³). 754 mm²/m per direction and face:
ρ = 0.31 % of the effective depth 0.24 m, above the minimum of EN 1992-1-1 9.3.1.1
(0.26 fctm/fyk ≈ 0.15 %) and about what a slab of this depth gets against a hard impact,
where the top face cracks too (a two-way mesh at each face is what codes for impact-loaded
slabs ask). The outer layers run along x (the span), the inner ones along y on them.
"""
import math

import numpy as np

from cases.reinforcement import Layer, bar_layout, layer_from_dict

DIAMETER, SPACING, COVER = 0.012, 0.15, 0.030      # m: the default mesh's bars
DEFAULT_MESH = tuple(
    Layer(DIAMETER, SPACING, direction, COVER + DIAMETER / 2 + k * DIAMETER, face)
    for face in ("bottom", "top") for k, direction in enumerate(("x", "y")))
# Bond–slip of ribbed bars in good bond conditions, pull-out failure (fib Model Code 2010,
# 6.1.1): τ_max = 2.5 √fck (MPa), reached at a slip s1 = 1 mm; fck = fcm − 8 MPa.
BOND_PEAK_SLIP = 1e-3               # m
FCK_MARGIN = 8e6                    # Pa, fcm − fck
YIELD_EVERY = 100                   # steps between the bars' yield records
ULTIMATE_STRAIN = 0.05              # εuk of class B steel (EN 1992-1-1 Annex C): ≥ 5 %


def layers(spec):
    """The slab's layers (SlabSpec.reinforcement, else DEFAULT_MESH if spec.reinforced)."""
    return checked_layers(spec.reinforcement, spec.reinforced)


def checked_layers(tables, reinforced, where="reinforcement"):
    """Layer objects of `tables` (Layers, or mappings: a case file's [[reinforcement]] tables,
    a summary's spec), checked in the slab's box; none given: DEFAULT_MESH if `reinforced`,
    else ()."""
    given = [layer if isinstance(layer, Layer) else layer_from_dict(layer, f"{where}[{k}]")
             for k, layer in enumerate(tables or ())]
    if not given and reinforced:
        given = list(DEFAULT_MESH)
    if given:
        from cases.slab.scales import SLAB
        bar_layout(given, (0.0, 0.0, 0.0), SLAB, where)
        other = [k for k, layer in enumerate(given)
                 if layer.bond_strength != given[0].bond_strength]
        if other:
            k = other[0]
            raise ValueError(f"{where}[{k}].bond_strength = {given[k].bond_strength!r}: every "
                             f"layer must have the same bond strength (one DE bond law), "
                             f"{where}[0] has {given[0].bond_strength!r}")
    return tuple(given)


def bond(spec):
    """The DE bond law: the layers' bond strength, else fib MC2010's τ_max; the secant
    slip stiffness to that peak."""
    from yade_side.bars import Bond
    given = spec.reinforcement[0].bond_strength
    tau = given if given is not None else \
        2.5e6 * math.sqrt((spec.compressive_strength - FCK_MARGIN) / 1e6)
    return Bond(tau, tau / BOND_PEAK_SLIP)


def model_bars(spec, model, bridging):
    """(DE bars, FE bars) of `model`: the full model's are all DE, the coupled model's cut at
    its DE zone (either may be None)."""
    from cases.bar_split import split_at_zone
    from cases.slab.scales import SLAB
    bars = bar_layout(spec.reinforcement, (0.0, 0.0, 0.0), SLAB)
    return (bars, None) if model == "full" else split_at_zone(bars, bridging)


class DEBars:
    """The chains of steel spheres of a model's DE bars (orchestrator.contracts.DEBars)."""

    def __init__(self, bars, radius, bond, beta):
        self.bars, self.radius, self.bond, self.beta = bars, radius, bond, beta
        self.chains, self.bond_count = None, 0

    def place(self):
        from yade import utils
        from yade_side.bars import SteelChains
        floor = utils.PWaveTimeStep()       # the concrete's: the bars must not shrink it
        self.chains = SteelChains(self.bars, self.radius, self.bond, floor)
        return self.chains.ids

    def start(self):
        self.bond_count = self.chains.bond_links()
        self.chains.start_plasticity(self.link_weights())

    def step(self):
        """The steel's law at the chains' strains after a step."""
        self.chains.plastic_step()

    def history(self):
        """The links' plastic state (their refPD comes back with the YADE scene)."""
        return self.chains.steel.history()

    def restore_history(self, history):
        self.chains.steel.restore_history(history)

    def link_weights(self):
        """The weight of every chain link (the mean β of its spheres, as weight_links gives
        it): a link's force is that share of the bar's."""
        if self.beta is None:
            return np.ones(len(self.chains.links))
        from yade_side.bulk import BodySet
        b = self.beta(BodySet(self.chains.ids).ref_pos)
        at = {int(i): b[k] for k, i in enumerate(self.chains.ids)}
        return np.array([0.5 * (at[a] + at[c]) for a, c, _ in self.chains.links])


def fe_bars(model, bars, element_length, weight):
    """The FE bars embedded in `model` (α = `weight` inside their stiffness and mass)."""
    from fenicsx_side.bars import EmbeddedBars
    embedded = EmbeddedBars(model, bars, element_length, weight=weight)
    embedded.add_to(model)
    return embedded


class YieldWatch:
    """Every YIELD_EVERY steps, the largest plastic strain |ε_p| of the DE chains and of the FE
    trusses, and when they first yielded; warnings() at the end: bars past the steel's
    ultimate strain, which the law does not break at."""

    def __init__(self, de, fe_bars):
        self.de, self.fe_bars = de, fe_bars
        self.worst = {"de": 0.0, "fe": 0.0}
        self.first = {}
        self.checks = 0

    def check(self, t):
        for side, steel in self._steel().items():
            eps = float(np.abs(steel.plastic).max(initial=0.0))
            self.worst[side] = max(self.worst[side], eps)
            if eps > 0 and side not in self.first:
                self.first[side] = t
        self.checks += 1

    def warnings(self):
        names = {"de": "DE steel chains", "fe": "FE embedded bars"}
        return [f"{names[side]}: plastic strain {self.worst[side]:.3g} past the steel's "
                f"ultimate strain {ULTIMATE_STRAIN:g} (EN 1992-1-1 Annex C, class B): the bars "
                f"would break there, the law does not" for side in ("de", "fe")
                if self.worst[side] > ULTIMATE_STRAIN]

    def _steel(self):
        """{side: its bars' plastic state} of the sides that have bars."""
        sides = {"de": None if self.de is None else self.de.chains.steel,
                 "fe": None if self.fe_bars is None else self.fe_bars.steel}
        return {side: steel for side, steel in sides.items() if steel is not None}

    def figures(self):
        return {"max_plastic_strain": dict(self.worst), "first_yield_s": dict(self.first),
                "plastic_work_J": {side: s.work for side, s in self._steel().items()},
                "yield_checks": self.checks, "check_every": YIELD_EVERY}
