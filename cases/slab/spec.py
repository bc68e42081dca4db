"""The slab case's description and every default it has: `SlabSpec`, and one table of scales.
The `slab` command's options and the case files' `kind = "slab"` schema are made from
SlabSpec's fields (orchestrator.casefile.spec_schema, cli.commands._options)."""
import math
from dataclasses import dataclass
from types import SimpleNamespace

from orchestrator.casefile import (DENSITY, FRACTURE_ENERGY, MODULUS, SEED, STRENGTH, boolean,
                                   check_spec, choice, integer, number, poisson_range,
                                   number_or_auto, relaxation_kind, safety_range,
                                   spec_key as key, step_count, within)
from orchestrator.coupling.bridging import WEIGHTINGS
from orchestrator.coupling.correction import VARIANTS
from orchestrator.run.autozone import (TripLevels, ahead_level, band_level, damage_level,
                                       omega_level, stress_level)
from cases.slab.scales import (CONCRETES, PER_SCALE, SCALES, SLAB, STEPS_SAFETY,
                               TABLE_DURATION, concrete_set, duration)


@dataclass
class SlabSpec:
    scale: str = key("small", choice(*SCALES), help="sphere size: small | medium | paper")
    seed: int = key(1, integer, SEED, help="packing realisation (slab and impactor)")
    radius: float = key(None, number, within(0, 0.1, "m"),
                        help="sphere radius (m); default per scale")
    de_zone: float = key(None, number, within(0, 100, "m"),
                         help="side of the DE zone (m), rounded to the FE grid; default per scale")
    full_width: bool = key(None, boolean, help="the DE zone spans the slab's whole width")
    fe_ratio: float = key(3.0, number, within(0, 20), help="in-plane FE size / sphere diameter")
    fe_ratio_thickness: float = key(1.5, number, within(0, 20),
                                    help="FE size through the thickness / sphere diameter")
    impactor_side: float = key(0.30, number, within(0, SLAB[1], "m"),
                               help="side of the cubic impactor (m)")
    impactor_speed: float = key(40.0, number, within(0, 1000, "m/s"), help="impact speed (m/s)")
    impactor_gap: float = key(0.002, number, within(0, 1, "m", low_open=False),
                              help="m the impactor falls before its first contact")
    elastic_outside: bool = key(False, boolean,
                                help="full model: links outside the coupled model's DE zone "
                                     "never damage, as the coupled model assumes")
    zone: str = key(None, choice("box", "auto", "grow"),
                    help="the coupled model's DE zone: 'grow': from the box zone (de_zone, "
                         "full_width), grown during the run where its checks trip "
                         "(docs/auto-zone.md); 'box': that zone, fixed; 'auto': grown by the "
                         "same checks, each time run again from t = 0; default 'grow', 'box' "
                         "for what a grown zone cannot carry (bars, a graded band, zone cells)")
    zone_start: float = key(None, number, within(0, 100, "m"), section="zone", name="start",
                            help="auto, grow: side (m) of a square start zone under the impact, "
                                 "rounded to the FE grid; default the box zone")
    zone_limit: float = key(None, number, within(0, 100, "m"), section="zone", name="limit",
                            help="auto, grow: length (m) along x of the centred full-width strip "
                                 "the zone may fill; default the slab less the supports and "
                                 "the band")
    fallback: str = key("none", choice("none", "full"), section="zone",
                        help="auto, grow: when the zone would pass its limit, stop ('none') or run "
                             "the full model ('full')")
    trip_stress: float = key(TripLevels.stress, number, stress_level, section="zone",
                             help="auto, grow, with fe.material 'elastic': an FE cell outside "
                                  "the band with σ1 >= this × ft trips (the FE cannot crack; 1 "
                                  "is the paper's check, which the post-run check keeps)")
    trip_omega: float = key(TripLevels.omega, number, omega_level, section="zone",
                            help="auto, grow: a bridging link with damage >= this trips (the "
                                 "coupling assumes an elastic band; 1: a broken link)")
    trip_band: float = key(None, number, band_level, section="zone",
                           help="auto, grow: a bridging sphere whose share of broken links "
                                "(its damage) >= this trips, instead of trip_omega's link "
                                "check (1: a sphere with no link left; docs/auto-zone.md)")
    trip_damage: float = key(TripLevels.damage, number, damage_level, section="zone",
                             help="auto, grow, with fe.material 'damage': an FE cell outside "
                                  "the band with damage >= this trips instead of its stress "
                                  "(0.9: 0.62-0.75 ft left in tension, docs/auto-zone.md); also "
                                  "the post-run check's level")
    stress_every: int = key(TripLevels.stress_every, integer, step_count, section="zone",
                            help="auto, grow: steps between FE stress checks")
    links_every: int = key(TripLevels.links_every, integer, step_count, section="zone",
                           help="auto, grow: steps between bridging link checks")
    zone_margin: int = key(TripLevels.margin, integer, within(1, 100, low_open=False),
                           section="zone", name="margin",
                           help="auto, grow: cells added around the flagged ones")
    zone_ahead: float = key(TripLevels.ahead, number, ahead_level, section="zone", name="ahead",
                            help="auto, grow: when an indicator trips, the cells past this × "
                                 "its level are flagged too (fewer, larger growths); 1: only "
                                 "those that tripped")
    zone_cost: float = key(0.5, number, within(0, 1e3, low_open=False), section="zone", name="cost",
                           help="auto: the search stops when the spheres × steps it has run, "
                                "plus one whole run of its last zone, reach this × the full "
                                "model's; grow: when those it has run, plus the rest of the "
                                "run in its zone, do (0.5: coupling pays when it at least "
                                "halves the full model's work; docs/auto-zone.md); 0: no such "
                                "limit")
    grow_shear: bool = key(False, boolean, section="zone", name="shear",
                           help="grow: the links of converted cells take the FE's shear strain "
                                "(affine) too, not only its normal strain: that adds 2-3 × the "
                                "energy the cells had (docs/auto-zone.md)")
    layers: int = key(None, integer, within(1, 20, low_open=False), section="coupling",
                      help="bridging layers; default per scale")
    band_ratio: float = key(None, number, within(0, 20), section="coupling",
                            help="in-plane size of the bridging band's FE cells / sphere "
                                 "diameter: a graded FE mesh, its cells growing by at most "
                                 "1.2 per cell from the band to fe_ratio's size away from it "
                                 "(box zones only, docs/performance.md); default: fe_ratio's "
                                 "uniform mesh")
    variant: str = key("diagonal", choice(*VARIANTS), section="coupling",
                       help="multiplier solver")
    weighting: str = key("consistent", choice(*WEIGHTINGS), section="coupling",
                         help="bridging weights: 'consistent' puts α, β inside the partners' "
                              "masses and stiffnesses (energy-conserving), 'nodal' is the "
                              "paper's (not conservative, docs/coupling.md)")
    relaxation: object = key("rho", relaxation_kind, within(0, 1e6), section="coupling",
                             help="relaxation r; 'rho': r = ρ, the model's lumping ratio, the "
                                  "least relaxation at which the diagonal correction exceeds "
                                  "the full one in no constraint mode (1.1-2.6 on the slabs; "
                                  "docs/slab-bias.md); "
                                  "'auto': the 1D band's rule against spurious reflections "
                                  "(docs/wave1d.md; r = 47.5 at small scale, one layer)")
    rotations: bool = key(True, boolean, section="coupling", help="couple sphere rotations")
    dt_safety: object = key(0.3, number_or_auto, safety_range, section="time",
                            help="× the smaller critical step, or 'auto': the run picks it by "
                                 "short pre-runs (cases/slab/timestep.py); without "
                                 "shear_release, 0.3 gains energy under a 40 m/s impact and "
                                 "even 0.15 overstates the damage (docs/performance.md)")
    shear_release: float = key(1.4e-4, number, within(0, 1, "s", low_open=False), section="time",
                               help="period (s) at which links past ω = 0.9 lose their shear "
                                    "stiffness: the crack friction that feeds energy into a "
                                    "cracked slab in proportion to the step (0: never; "
                                    "docs/performance.md)")
    steps: int = key(None, integer, step_count, section="time",
                     help="steps; default per scale and impact speed: the impact's measured "
                          "duration (cases/slab/scales.py)")
    sample_every: int = key(5, integer, step_count, section="output",
                            help="steps between sensor samples")
    check_every: int = key(50, integer, step_count, section="output",
                           help="steps between energy and blow-up checks")
    output_every: int = key(200, integer, step_count, section="output", name="every",
                            help="steps between ParaView frames")
    checkpoint_every: int = key(1000, integer, step_count, section="output",
                                help="steps between checkpoints")
    energy_split: bool = key(True, boolean, section="output",
                             help="record where the impact's energy goes, by kind and place "
                                  "(cases/slab/energies.py; its cost: docs/slab.md)")
    young: float = key(None, number, MODULUS, section="material",
                       help="FE modulus (Pa); default per scale (the DE slab's bending modulus)")
    poisson: float = key(None, number, poisson_range, section="material",
                         help="FE Poisson ratio; default the concrete's measured ν")
    density: float = key(2400.0, number, DENSITY, section="material", help="kg/m³")
    concrete: str = key("plain", choice(*CONCRETES), section="material",
                        help="the spheres' CPM set of the scale: 'plain' (fitted to E, fc) or "
                             "'gf' (also towards the fracture energy; small and medium, "
                             "docs/calibration.md)")
    compressive_strength: float = key(None, number, STRENGTH, section="material",
                                      help="fc (Pa) of the FE damage law and the post-run FE "
                                           "check; default the concrete's measured fc")
    tensile_strength: float = key(None, number, STRENGTH, section="material",
                                  help="ft (Pa) of the FE damage law and the post-run FE "
                                       "check; default the concrete's measured ft")
    fracture_energy: float = key(None, number, FRACTURE_ENERGY, section="material",
                                 help="Gf (J/m²) of the FE damage law; default the concrete's "
                                      "separation test")
    compressive_fracture_energy: float = key(
        None, number, FRACTURE_ENERGY, section="material",
        help="Gc (J/m²) of the FE damage law's compression band; default fitted to the "
             "post-peak branch of the concrete's compression test on the slab's FE cells "
             "(docs/fe-damage.md)")
    fe_material: str = key("elastic", choice("elastic", "damage"), section="fe",
                           name="material",
                           help="the FE part: 'elastic', as in the paper, or 'damage': the "
                                "concrete damage law with the spheres' measured ft, fc, Gf "
                                "(docs/fe-damage.md)")
    reinforced: bool = key(False, boolean,
                           help="bars: the case file's [[reinforcement]] layers, else a "
                                "two-way mesh of 12 mm bars at 150 mm at both faces, 30 mm "
                                "cover (docs/reinforcement.md)")
    mpi: int = key(0, integer, lambda v: None if v == 0 or v >= 2 else
                   "0 (one process) or >= 2 (rank 0 drives, the others own the spheres)",
                   help="full model: MPI ranks of YADE's own yade.mpy, launched with mpiexec "
                        "(docs/mpi.md); 0: one process")
    relaxation_rule: str = None      # set by relaxation "auto": what the rule took r from
    dt_choice: dict = None           # set after dt_safety "auto": what the pre-runs found
    reinforcement: tuple = None      # the bars' layers (cases.reinforcement.Layer, checked)
    zone_cells: tuple = None         # a fixed DE zone of in-plane cells (i, j), instead of the
                                     # box: one a zone "auto" or "grow" run found (--zone-from)

    def __post_init__(self):
        check_spec(self, "slab")
        from cases.slab.reinforced import layers
        self.reinforcement = layers(self)
        self.reinforced = bool(self.reinforcement)
        if self.zone is None:
            fixed = self.reinforced or self.band_ratio is not None or self.zone_cells is not None
            self.zone = "box" if fixed else "grow"
        table = SCALES[self.scale]
        material = concrete_set(self.scale, self.concrete)
        if material is None:
            have = ", ".join(name for name in SCALES if concrete_set(name, self.concrete))
            raise ValueError(f"slab: concrete {self.concrete!r} has no calibrated set at scale "
                             f"{self.scale!r} (only {have})")
        for name in ("poisson", "compressive_strength", "tensile_strength", "fracture_energy"):
            if getattr(self, name) is None:
                setattr(self, name, getattr(material, name))
        chosen = self.dt_safety != "auto"     # else steps and r once the run has chosen dt
        if self.steps is None and chosen:
            # the table's steps over its duration, or the measured one of this impact: the
            # critical step is ∝ 1/√young
            length = duration(self.scale, self.impactor_speed) / TABLE_DURATION
            self.steps = math.ceil(round(table.steps * length * STEPS_SAFETY / self.dt_safety
                                         * math.sqrt(material.cpm["young"] / concrete_set(
                                             self.scale, "plain").cpm["young"]), 6))
        for name, column in PER_SCALE.items():
            if getattr(self, name) is None:
                setattr(self, name, getattr(table, column))
        if self.fe_material == "damage":
            self._check_damage(material)
        if self.mpi and self.dt_safety == "auto":
            raise ValueError(f"slab: mpi = {self.mpi} splits the scene once: not with "
                             f"dt_safety 'auto', whose pre-runs build it again")
        if self.mpi and (self.reinforced or self.elastic_outside):
            raise ValueError(f"slab: mpi = {self.mpi} runs the plain full slab: not with "
                             f"{'reinforcement' if self.reinforced else 'elastic_outside'} "
                             f"(their links are set up in one process)")
        if self.band_ratio is not None:
            if self.zone != "box":
                raise ValueError(f"slab: band_ratio (a graded FE mesh) applies to box zones, "
                                 f"not to zone {self.zone!r}")
            if self.band_ratio > self.fe_ratio:
                raise ValueError(f"slab: band_ratio = {self.band_ratio!r} must not exceed "
                                 f"fe_ratio = {self.fe_ratio!r} (the band's cells are the "
                                 f"finest)")
        if self.zone != "box":
            from cases.slab.zone import check
            check(self)
        if self.zone_cells is not None:
            self._check_cells()
        if self.relaxation == "auto" and chosen:
            from cases.slab.zone import slab_grid
            from orchestrator.coupling.relaxation import auto_relaxation
            ratio = slab_grid(self).band_h / (2 * self.radius)
            self.relaxation = float(auto_relaxation(ratio, self.layers, self.variant,
                                                    self.dt_safety, self.weighting))
            self.relaxation_rule = (f"relaxation auto: the 1D band's r with the most margin to "
                                    f"the goal at ratio {ratio:.3g}, n_b = {self.layers}, dt = "
                                    f"{self.dt_safety:g} × critical, {self.variant}, "
                                    f"{self.weighting} (docs/wave1d.md)")

    def inert(self, model, given):
        """The first of the keys `given` (field names) that cannot act on a `model` run of
        this spec, and what it needs; None when every one acts."""
        for name in given:
            acts, needs = NEEDS.get(name, (None, None))
            if acts is not None and not acts(self, model):
                return name, needs
        return None

    @staticmethod
    def zone_for(model, zone, name):
        """The zone of a `model` run given `zone` as the option or key `name` (None: not
        given): the full model has no DE zone (its sensors sit where the box zone's would), so
        a zone found by the coupled model's checks is refused there (ValueError, one line)."""
        if model != "full":
            return zone
        if zone not in (None, "box"):
            raise ValueError(f"{name} {zone} finds the DE zone of a coupled model: the full "
                             f"model has none (run it as the coupled model)")
        return "box"

    @property
    def cpm(self):
        """The CPM micro-parameters of the scale's `concrete`."""
        return concrete_set(self.scale, self.concrete).cpm

    def damage_law(self):
        """The FE damage law (fenicsx_side.damage_law.ConcreteDamage's fields)."""
        return dict(young=self.young, poisson=self.poisson,
                    tensile_strength=self.tensile_strength,
                    compressive_strength=self.compressive_strength,
                    fracture_energy=self.fracture_energy,
                    compressive_fracture_energy=self.compressive_fracture_energy)

    def _check_cells(self):
        if self.zone != "box":
            raise ValueError(f"slab: zone cells make a fixed zone, not one of zone "
                             f"{self.zone!r}")
        from cases.slab.zone import cells_grid
        try:
            self.zone_cells = tuple((int(i), int(j)) for i, j in self.zone_cells)
            cells_grid(self, self.zone_cells)
        except (TypeError, ValueError, IndexError):
            raise ValueError(f"slab: zone cells must be (i, j) indices of the slab's in-plane "
                             f"FE cells at scale {self.scale!r}, got "
                             f"{str(self.zone_cells)[:80]}") from None

    def _check_damage(self, material):
        if self.fracture_energy is None:
            raise ValueError(f"slab: fe.material 'damage' needs a fracture energy: the "
                             f"{self.concrete!r} set at scale {self.scale!r} has no separation "
                             f"test ({material.record}); give material.fracture_energy "
                             f"(--fracture-energy)")
        from cases.slab.zone import slab_grid
        from fenicsx_side.damage_law import ConcreteDamage
        grid = slab_grid(self)
        widest = max(grid.h, SLAB[2] / grid.n[2])      # no cell is wider along any direction
        if self.compressive_fracture_energy is None:
            self.compressive_fracture_energy = material.compressive_fracture_energy(
                self.young, widest)
        try:
            law = ConcreteDamage(**self.damage_law())
        except ValueError as e:
            raise ValueError(f"slab: {e}") from None
        if widest >= law.max_element_size:
            raise ValueError(f"slab: FE cells {widest:.3g} m wide are beyond the crack band's "
                             f"limit 2 M Gf / ft² = {law.max_element_size:.3g} m: a smaller "
                             f"fe_ratio, or a larger fracture_energy")
        if widest >= law.max_compressive_element_size:
            raise ValueError(f"slab: compressive_fracture_energy = "
                             f"{self.compressive_fracture_energy:.4g} J/m² would snap back on "
                             f"FE cells {widest:.3g} m wide: it must exceed fc² h / 2E = "
                             f"{self.compressive_strength ** 2 * widest / (2 * self.young):.4g}"
                             f" J/m² (or a smaller fe_ratio)")


# What each key needs to act on a run (model: "full" or "coupled"): given where it cannot, it
# is refused (SlabSpec.inert), never recorded as if it had been used.
def _coupled(s, m):
    return m == "coupled"


def _grown(s, m):
    return m == "coupled" and s.zone in ("auto", "grow")


NEEDS = {
    "elastic_outside": (lambda s, m: m == "full", "the full model"),
    "mpi": (lambda s, m: m == "full", "the full model"),
    "checkpoint_every": (lambda s, m: not s.mpi, "a run in one process (an MPI run keeps no "
                                                 "checkpoint: its YADE scene is split over the "
                                                 "ranks)"),
    **{k: (_coupled, "the coupled model (the FE and the coupling)")
       for k in ("band_ratio", "variant", "weighting", "relaxation", "rotations", "young",
                 "poisson", "fe_material", "tensile_strength")},
    "compressive_strength": (lambda s, m: m == "coupled" or s.reinforced,
                             "the coupled model (its FE) or bars (their bond)"),
    **{k: (lambda s, m: m == "coupled" and s.fe_material == "damage",
           "the coupled model with fe.material 'damage'")
       for k in ("fracture_energy", "compressive_fracture_energy", "trip_damage")},
    **{k: (_grown, "the coupled model with zone 'auto' or 'grow'")
       for k in ("zone_start", "zone_limit", "fallback", "trip_band", "stress_every",
                 "links_every", "zone_margin", "zone_ahead", "zone_cost")},
    "trip_omega": (lambda s, m: _grown(s, m) and s.trip_band is None,
                   "the coupled model with zone 'auto' or 'grow' and no trip_band (which "
                   "replaces its link check)"),
    "trip_stress": (lambda s, m: _grown(s, m) and s.fe_material == "elastic",
                    "the coupled model with zone 'auto' or 'grow' and fe.material 'elastic'"),
    "grow_shear": (lambda s, m: m == "coupled" and s.zone == "grow",
                   "the coupled model with zone 'grow'"),
}


def inert_fields(values, model):
    """The fields of a description ({field: value}, every field given) that cannot act on a
    `model` run (NEEDS); the relaxation rule's record goes with the relaxation."""
    view = SimpleNamespace(**values)
    inert = {k for k, (acts, _) in NEEDS.items() if not acts(view, model)}
    return inert | ({"relaxation_rule"} if "relaxation" in inert else set())
