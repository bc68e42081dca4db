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
YIELD_EVERY = 100                   # steps between the bars' yield checks


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
    """Every YIELD_EVERY steps, the largest |σ| / fy of the DE chains (a link's force over its
    weight: the whole bar's stress) and of the FE trusses; warnings() at the end."""

    def __init__(self, de, fe_bars, fe):
        self.de, self.fe_bars, self.fe = de, fe_bars, fe
        self.weights = None if de is None else de.link_weights()
        self.worst = {"de": 0.0, "fe": 0.0}
        self.first = {}
        self.checks = 0

    def check(self, t):
        ratios = {}
        if self.de is not None:
            _, r = self.de.chains.check_yield(warn=False)
            ratios["de"] = float(np.max(r / self.weights, initial=0.0))
        if self.fe_bars is not None:
            ratios["fe"] = float(np.max(self.fe_bars.yield_ratio(self.fe.u), initial=0.0))
        for side, r in ratios.items():
            self.worst[side] = max(self.worst[side], r)
            if r > 1.0 and side not in self.first:
                self.first[side] = t
        self.checks += 1

    def warnings(self):
        names = {"de": "DE steel chains", "fe": "FE embedded bars"}
        return [f"{names[side]}: bar stress passed fy (max |σ|/fy {self.worst[side]:.3g} over "
                f"{self.checks} checks every {YIELD_EVERY} steps, first at t = "
                f"{1e3 * self.first[side]:.3g} ms): the steel is elastic, its forces there "
                f"are overestimated" for side in ("de", "fe") if side in self.first]

    def figures(self):
        return {"max_stress_over_fy": dict(self.worst), "yield_checks": self.checks,
                "check_every": YIELD_EVERY}
