"""Slab impact (the paper's §5): a concrete cube of spheres hits a simply supported slab.

One description, two models:
- full: the whole slab in spheres (YADE alone);
- coupled: spheres in a central DE zone through the thickness plus a bridging band of
  `layers` FE element layers around it; FE (dolfinx) everywhere outside the DE zone.
Both models take their slab spheres from the same packing of the whole slab, so the DE
zone's micro-structure is the same in both and damage maps compare sphere by sphere.
"""
from dataclasses import asdict, dataclass
from time import perf_counter

import numpy as np

from orchestrator.runner import damage_map, read_sensors

SLAB = (2.5, 2.0, 0.28)
# sphere radius per scale: 25,072 spheres in the full medium model, 122,066 at paper scale (the
# issue's ~25,000 and Table 1's 120,808); the FE size is a multiple of the diameter (SlabSpec)
SCALES = {"small": 0.025, "medium": 0.0185, "paper": 0.0112}
# 5 ms after contact at small and medium scale: the far sensors reach their peak (~2.5-4 ms)
DEFAULT_STEPS = {"small": 3300, "medium": 4400, "paper": 300}
# FE modulus per scale: the bending modulus of the DE slab it stands for, measured by quasi-static
# 3-point bending of a strip of the slab's packing against the same strip in FE on the scale's
# grid (`python3 -m cases.slab_bending --scale S`). 5.6-7.6 sphere diameters through 0.28 m bend
# like 17-21 GPa, not the 29-31 GPa of their uniaxial test: an FE at 31 GPa made the coupled
# slab about twice as stiff as the full one. 12.5 diameters (paper scale) bend like 24.9 GPa.
FE_YOUNG = {"small": 17.2e9, "medium": 21.0e9, "paper": 24.9e9}
# CPM micro-parameters per scale, fitted by `python3 -m orchestrator calibrate --scale S` to
# E = 31 GPa and fc = 31 MPa on a 0.56 × 0.56 × 0.28 m piece of the slab's packing, with broken
# links deleted (docs/calibration.md: E 31.02 / 31.00 / 30.98 GPa, fc 30.90 / 31.02 / 30.90
# MPa), and the tensile strength the same test measured (ft, for the post-run check of the FE
# stresses). FE_YOUNG is elastic: it does not depend on the strength parameters.
CPM = {"small": dict(young=3.301e10, sigmaT=5.702e6, epsCrackOnset=1.188e-4),
       "medium": dict(young=3.137e10, sigmaT=4.375e6, epsCrackOnset=9.561e-5),
       "paper": dict(young=2.833e10, sigmaT=3.519e6, epsCrackOnset=8.476e-5)}
TENSILE_STRENGTH = {"small": 4.30e6, "medium": 3.76e6, "paper": 3.14e6}
# The DE zone: its side along x (m, rounded to the FE grid) and whether it spans the slab's whole
# width (y). 40 m/s perforates the slab at small and medium scale, and within 5 ms damage reaches
# the free edges y = 0, 2: a strip x ∈ [0.83, 1.67] m holds 98.9 % of the full small model's
# damaged volume, x ∈ [0.8, 1.7] m 96.7 % of the medium one's (a 0.7 × 0.6 m box: 81 %).
DE_ZONE = {"small": 0.6, "medium": 0.9, "paper": 0.6}
FULL_WIDTH = {"small": True, "medium": True, "paper": False}


@dataclass
class SlabSpec:
    scale: str = "small"
    radius: float = None             # default: SCALES[scale]
    de_zone: float = None            # side of the DE zone (m), rounded to the FE grid;
                                     # default DE_ZONE[scale]
    full_width: bool = None          # DE zone through the whole width; default FULL_WIDTH[scale]
    layers: int = 3                  # bridging layers
    fe_ratio: float = 3.0            # in-plane FE size / sphere diameter
    fe_ratio_thickness: float = 1.5  # FE size through the thickness / sphere diameter
    impactor_side: float = 0.30
    impactor_speed: float = 40.0
    impactor_gap: float = 0.002      # m the impactor travels before its first contact
    variant: str = "diagonal"
    weighting: str = "consistent"    # or "nodal" (the paper's: not conservative, docs/slab.md)
    elastic_outside: bool = False    # full model: links outside the DE zone never damage, as
                                     # the coupled model assumes (the coupling error alone)
    relaxation: float = 35.0         # or "auto": the rule of the 1D study (docs/wave1d.md)
    rotations: bool = True
    dt_safety: float = 0.15          # × the smaller critical step: at 0.3 the slab gains energy
                                     # and disintegrates under a 40 m/s impact (docs/slab.md)
    steps: int = None                # default: DEFAULT_STEPS[scale]
    sample_every: int = 5            # sensor histories
    check_every: int = 50            # damage, energy and blow-up check
    output_every: int = 200          # ParaView frames
    checkpoint_every: int = 1000     # checkpoints (resume with --resume)
    young: float = None              # FE modulus (Pa); default FE_YOUNG[scale]
    poisson: float = 0.2
    density: float = 2400.0
    compressive_strength: float = 31e6
    tensile_strength: float = None   # Pa; default TENSILE_STRENGTH[scale] (calibration)

    def __post_init__(self):
        from orchestrator.bridging import check_weighting
        check_weighting("slab", self.weighting)
        if self.scale not in SCALES:
            raise ValueError(f"scale must be one of {tuple(SCALES)}, got {self.scale!r}")
        self.radius = SCALES[self.scale] if self.radius is None else self.radius
        self.steps = DEFAULT_STEPS[self.scale] if self.steps is None else self.steps
        self.young = FE_YOUNG[self.scale] if self.young is None else self.young
        if self.tensile_strength is None:
            self.tensile_strength = TENSILE_STRENGTH[self.scale]
        self.full_width = FULL_WIDTH[self.scale] if self.full_width is None else self.full_width
        self.de_zone = DE_ZONE[self.scale] if self.de_zone is None else self.de_zone
        for name in ("radius", "de_zone", "fe_ratio", "fe_ratio_thickness", "impactor_side",
                     "young", "density"):
            if not getattr(self, name) > 0:
                raise ValueError(f"slab: {name} must be > 0, got {getattr(self, name)!r}")
        if not self.impactor_gap >= 0:
            raise ValueError(f"slab: impactor_gap must be >= 0, got {self.impactor_gap!r}")
        if not 0 < self.dt_safety <= 1:
            raise ValueError(f"slab: dt_safety must be in (0, 1], got {self.dt_safety!r}")
        if int(self.steps) != self.steps or self.steps < 1:
            raise ValueError(f"slab: steps must be a positive integer, got {self.steps!r}")
        if self.relaxation == "auto":
            from cases.wave1d import auto_relaxation
            ratio = slab_grid(self).h / (2 * self.radius)
            self.relaxation = float(auto_relaxation(ratio, self.layers, self.variant,
                                                    self.dt_safety))
        if not self.relaxation > 0:
            raise ValueError(f"slab: relaxation must be > 0 or 'auto', got {self.relaxation!r}")


@dataclass
class Grid:
    """The FE grid of the slab (square in-plane cells of size h) and the DE zone on it."""
    h: float
    n: tuple
    hole_lo: np.ndarray
    hole_hi: np.ndarray
    axes: tuple = (0, 1)  # the axes along which the DE zone is bounded

    @property
    def width(self):
        return self.hole_hi - self.hole_lo


def slab_grid(spec):
    """In-plane size h = 0.5/k m closest to fe_ratio × diameter, so that both 2.5 m and 2 m
    are whole numbers of cells; DE zone = the central block of cells nearest de_zone (along x
    only with full_width)."""
    k = max(1, round(0.5 / (spec.fe_ratio * 2 * spec.radius)))
    h = 0.5 / k
    n = [round(SLAB[0] / h), round(SLAB[1] / h),
         max(1, round(SLAB[2] / (spec.fe_ratio_thickness * 2 * spec.radius)))]
    lo, hi = np.zeros(3), np.array(SLAB)
    axes = (0,) if spec.full_width else (0, 1)
    for axis in axes:
        cells = max(1, round(spec.de_zone / h))
        if (n[axis] - cells) % 2:  # centred on the slab
            cells += 1
        start = (n[axis] - cells) // 2
        if start < spec.layers + 1:
            raise ValueError(f"slab: a DE zone of {cells} cells and {spec.layers} bridging "
                             f"layers do not fit in the {n[axis]} cells along axis {axis} with "
                             f"FE beyond them; reduce de_zone or layers, or the sphere radius")
        lo[axis], hi[axis] = start * h, (start + cells) * h
    return Grid(h, tuple(n), lo, hi, axes)


@dataclass
class Packings:
    slab_centres: np.ndarray
    slab_radii: np.ndarray
    slab_fraction: float
    impactor_centres: np.ndarray
    impactor_radii: np.ndarray
    impactor_drop: float  # lowered by this once the cohesive links are made: spec.impactor_gap


def make_packings(spec):
    """The slab's and the impactor's spheres. The impactor sits 1.05 × beyond the reach of the
    cohesive links made in the first step (1.5 × the sum of radii: no link joins it to the
    slab); lowered by impactor_drop after that step, it touches the slab after a fall of
    impactor_gap."""
    from yade_side.packing import dense_box_packing, packing_fraction, sphere_arrays
    from yade_side.scene import INTERACTION_RADIUS
    slab_c, slab_r = sphere_arrays(dense_box_packing((0, 0, 0), SLAB, spec.radius))
    a = spec.impactor_side
    imp_c, imp_r = sphere_arrays(dense_box_packing((0, 0, 0), (a, a, a), spec.radius, seed=2))
    imp_c = imp_c + [0.5 * (SLAB[0] - a), 0.5 * (SLAB[1] - a), -np.min(imp_c[:, 2])]
    lift = _impactor_height(imp_c, imp_r, slab_c, slab_r, 1.05 * INTERACTION_RADIUS)
    touch = _impactor_height(imp_c, imp_r, slab_c, slab_r, 1.0)
    imp_c[:, 2] += lift
    return Packings(slab_c, slab_r, packing_fraction(slab_r, np.prod(SLAB)), imp_c, imp_r,
                    lift - touch - spec.impactor_gap)


def _impactor_height(imp_c, imp_r, slab_c, slab_r, reach):
    """The lowest lift of the impactor (centred over the slab, lowest centre at z = 0) that
    keeps every impactor-slab pair at least `reach` × its sum of radii apart."""
    reach_max = reach * 2 * max(imp_r.max(), slab_r.max())
    lo, hi = imp_c[:, :2].min(axis=0) - reach_max, imp_c[:, :2].max(axis=0) + reach_max
    near = np.all((slab_c[:, :2] > lo) & (slab_c[:, :2] < hi), axis=1)
    near &= slab_c[:, 2] > slab_c[near, 2].max() - reach_max
    low = imp_c[:, 2] < reach_max
    s_c, i_c = slab_c[near], imp_c[low]
    pair_reach = reach * (imp_r[low][:, None] + slab_r[near][None, :])
    lateral = np.linalg.norm(i_c[:, None, :2] - s_c[None, :, :2], axis=2)
    rise = np.sqrt(np.maximum(pair_reach**2 - lateral**2, 0.0))  # vertical centre gap needed
    rise = np.where(lateral < pair_reach, rise + s_c[None, :, 2] - i_c[:, None, 2], -np.inf)
    return float(rise.max())


def sensor_points(spec, grid):
    xc, yc = 0.5 * SLAB[0], 0.5 * SLAB[1]
    zmid = 0.5 * SLAB[2]
    w = spec.layers * grid.h
    away = 0.5 * (xc + 0.5 * spec.impactor_side + grid.hole_hi[0])
    return {
        "under_impact": (xc, yc, spec.radius),
        "de_zone": (away, yc, zmid),
        "bridging": (grid.hole_hi[0] + 0.5 * w, yc, zmid),
    }


def concrete(spec):
    """The slab's CPM parameters: the calibrated set of its scale, its bulk density."""
    from yade_side.material import ConcreteParams
    return ConcreteParams(density=spec.density, **CPM[spec.scale])


def slab_bridging(spec, grid):
    from orchestrator.bridging import BoxZone, Bridging
    return Bridging(BoxZone(grid.hole_lo, grid.hole_hi, grid.axes), spec.layers, grid.h)


def fe_model(spec, grid):
    """The coupled model's FE part: the slab less the DE zone, its x = 0 and x = 2.5 faces held
    in z (simple supports); with the consistent weighting, stiffness and mass weighted by α.
    Collective under MPI: every rank builds it."""
    from fenicsx_side.mesh import box_mesh_with_hole
    from fenicsx_side.model import ElasticModel, face
    msh = box_mesh_with_hole((0, 0, 0), SLAB, grid.n, grid.hole_lo, grid.hole_hi)
    supports = [(face(0, 0.0), (2,)), (face(0, SLAB[0]), (2,))]
    weight = slab_bridging(spec, grid).alpha if spec.weighting == "consistent" else None
    return ElasticModel(msh, spec.young, spec.poisson, spec.density, supports, weight=weight)


class SlabModel:
    """Builds the YADE scene (and for `coupled` the FE model and the coupling), then steps."""

    def __init__(self, spec, model):
        if model not in ("full", "coupled"):
            raise ValueError(f"model must be 'full' or 'coupled', got {model!r}")
        if spec.elastic_outside and model != "full":
            raise ValueError("elastic_outside applies to the full model only (the coupled "
                             "model has FE outside its DE zone)")
        from orchestrator.assembly import bridging_spheres, check_time_step, common_time_step
        from yade_side import import_yade
        from yade_side.bulk import BodySet
        from yade_side.damage import LinkDamage
        from yade_side.material import cpm_material
        from yade_side.packing import add_spheres
        from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

        yade = import_yade()
        from yade import utils
        self.O = O = yade.Omega()
        self.spec, self.model = spec, model
        self.grid = grid = slab_grid(spec)
        packs = make_packings(spec)
        self.bridging = slab_bridging(spec, grid)
        keep = np.arange(len(packs.slab_radii))
        if model == "coupled":
            keep = np.flatnonzero(self.bridging.zone.depth(packs.slab_centres)
                                  <= self.bridging.width)
        self.slab_index = keep  # indices into the whole-slab packing

        reset_scene()
        mat = cpm_material(concrete(spec), packs.slab_fraction)
        self.slab_ids = add_spheres(packs.slab_centres[keep], packs.slab_radii[keep], mat)
        self.impactor_ids = add_spheres(packs.impactor_centres, packs.impactor_radii, mat)
        self.radius = packs.slab_radii[keep]

        self.fe = None
        fe_critical = np.inf
        if model == "coupled":
            from fenicsx_side.distributed import on_rank_zero
            self.fe = on_rank_zero(fe_model(spec, grid))
            fe_critical = self.fe.critical_dt()
        else:
            # simple supports: spheres touching the x = 0 and x = 2.5 faces keep z fixed
            c, r = packs.slab_centres, packs.slab_radii
            on_support = (c[:, 0] < 2 * r) | (c[:, 0] > SLAB[0] - 2 * r)
            for i in self.slab_ids[on_support]:
                O.bodies[int(i)].state.blockedDOFs = "z"
            self.support_ids = self.slab_ids[on_support]
        de_critical = utils.PWaveTimeStep()
        self.dt = common_time_step(spec.dt_safety, de_critical, fe_critical)
        check_time_step(self.dt, de_critical, fe_critical)
        self.critical = {"de": de_critical, "fe": None if self.fe is None else fe_critical}
        cpm_engines(dt=self.dt)
        create_cohesive_links()
        self.elastic_links = 0
        if spec.elastic_outside:
            from yade_side.damage import keep_links_elastic
            self.elastic_links = keep_links_elastic(lambda p: self.bridging.zone.depth(p) > 0)
        consistent = model == "coupled" and spec.weighting == "consistent"
        if consistent:
            from yade_side.weighting import weight_spheres
            weight_spheres(self.slab_ids, self.bridging.beta(packs.slab_centres[keep]))

        self.slab = BodySet(self.slab_ids)
        self.impactor = BodySet(self.impactor_ids)
        self.impactor.move(np.array([0.0, 0.0, -packs.impactor_drop]))
        self.impactor.set_velocity(np.array([0.0, 0.0, -spec.impactor_speed]))
        self.damage = LinkDamage(self.slab_ids)
        self.damage.record_initial()
        self.initial_links = int(self.damage.initial.sum())

        self.stepper = None
        self.bridge_index = np.empty(0, int)
        if model == "coupled":
            from orchestrator.assembly import make_coupling
            from orchestrator.timeloop import CoupledStepper
            self.bridge_index = bridging_spheres(self.bridging, self.slab.ref_pos)
            self.bridge = BodySet(self.slab_ids[self.bridge_index])
            coupling = make_coupling(self.fe, self.bridging, self.bridge, self.dt, spec.variant,
                                     spec.relaxation, spec.rotations,
                                     nodal_weights=not consistent)
            self.stepper = CoupledStepper(O.step, self.bridge, self.fe, coupling)
        self.in_de_zone = self.bridging.zone.depth(self.slab.ref_pos) < 0
        self._sensor_setup()
        self.seconds = {"yade": 0.0, "fe": 0.0, "coupling": 0.0, "output": 0.0}
        self.steps = 0

    def _sensor_setup(self):
        points = sensor_points(self.spec, self.grid)
        names = list(points)
        idx = [int(np.argmin(np.linalg.norm(self.slab.ref_pos - p, axis=1))) for p in points.values()]
        # the FE node nearest to the bridging sensor; in the full model, the sphere nearest to
        # that node's position (the node lies on the same grid in both models)
        node_point = self._fe_node_position(self.slab.ref_pos[idx[-1]])
        names.append("fe_node")
        if self.fe is not None:
            self.fe_node = int(np.argmin(np.linalg.norm(self.fe.nodes - node_point, axis=1)))
        else:
            idx.append(int(np.argmin(np.linalg.norm(self.slab.ref_pos - node_point, axis=1))))
        from yade_side.bulk import BodySet
        self.sensor_names = names
        self.sensor_spheres = BodySet(self.slab_ids[idx])
        self.sensor_positions = np.vstack([self.slab.ref_pos[idx], node_point])

    def _fe_node_position(self, x):
        """Nearest node of the FE grid (the structured grid of both models)."""
        h, hz = self.grid.h, SLAB[2] / self.grid.n[2]
        return np.array([round(x[0] / h) * h, round(x[1] / h) * h, round(x[2] / hz) * hz])

    def step(self):
        if self.stepper is None:
            t0 = perf_counter()
            self.O.step()
            self.seconds["yade"] += perf_counter() - t0
        else:
            self.stepper.step()
            for key, value in self.stepper.seconds.items():
                self.seconds[key] = value
        self.steps += 1

    def sensor_displacements(self):
        """(n_sensors, 3) displacements now."""
        self.sensor_spheres.read()
        d = self.sensor_spheres.displacement()
        if self.fe is not None:
            d = np.vstack([d, self.fe.u[3 * self.fe_node:3 * self.fe_node + 3]])
        return d

    def energy(self):
        """Kinetic (spheres, FE) + CPM elastic + FE strain energy (the bridging overlap is
        counted by both models: a diagnostic for blow-ups, not a balance). YADE's
        Law2_ScGeom_CpmPhys_Cpm.elasticEnergy() turns NaN once impactor and slab touch
        (measured here); it is then left out and the kinetic energy alone is guarded."""
        self.slab.read()
        self.impactor.read()
        e = self.slab.kinetic_energy() + self.impactor.kinetic_energy()
        if self.fe is not None:
            e += self.fe.kinetic_energy() + self.fe.strain_energy()
        from yade_side.scene import cpm_law
        elastic = cpm_law().elasticEnergy()  # looked up: a loaded checkpoint replaces engines
        return e + elastic if np.isfinite(elastic) else e

    def sphere_count(self):
        return len(self.slab_ids) + len(self.impactor_ids)


def run(spec, model, out, quiet=False, resume=False):
    """Run one model to spec.steps and write its results folder `out` (already prepared), or
    carry on from its checkpoint (resume)."""
    from orchestrator import runner
    t_build = perf_counter()
    m = SlabModel(spec, model)
    build_s = perf_counter() - t_build
    impact_energy = 0.5 * m.impactor.mass.sum() * spec.impactor_speed**2
    info = {"model": model, "spec": asdict(spec), "n_slab_spheres": len(m.slab_ids),
            "build_s": build_s, "impact_energy_J": impact_energy,
            "links_kept_elastic": m.elastic_links}
    schedule = runner.Schedule(spec.steps, spec.sample_every, spec.check_every,
                               spec.output_every, spec.checkpoint_every)
    return runner.run(m, m.slab, schedule, out, f"slab {model} ({spec.scale})", impact_energy,
                      info=info, arrays={"slab_index": m.slab_index},
                      checks=lambda damage: _post_run_checks(m, damage), quiet=quiet,
                      resume=resume)


def _post_run_checks(m, damage):
    """The paper's two checks: the FE stays elastic; the bridging spheres stay undamaged. For
    the full model, their counterpart: links where the coupled model has its band and FE that
    passed their tensile strength (ω > 0), which an elastic FE there cannot follow."""
    from orchestrator.runner import post_run_checks
    warnings = post_run_checks(m.fe, damage[m.bridge_index], m.spec.tensile_strength,
                               m.spec.compressive_strength)
    if m.fe is None and not m.spec.elastic_outside:
        from yade_side.damage import link_damage
        omega = link_damage(lambda p: m.bridging.zone.depth(p) > 0)
        cracked = np.count_nonzero(omega > 0)
        if cracked:
            warnings.append(f"{cracked} of the {omega.size} links outside the coupled model's DE "
                            f"zone are partly damaged (mean ω {omega.mean():.3f}): a coupled "
                            f"model, elastic there, will be stiffer (docs/slab.md)")
    return warnings


def compare(full_dir, coupled_dir, out):
    """Coupled against full: sensor histories, damage, cost. Writes comparison.json + PNGs."""
    import json
    from orchestrator.results import write_json
    runs = {}
    for key, folder in (("full", full_dir), ("coupled", coupled_dir)):
        summary = json.loads((folder / "summary.json").read_text())
        if summary["model"] != key:
            raise ValueError(f"{folder} holds a {summary['model']!r} run, expected {key!r}")
        runs[key] = (summary, read_sensors(folder / "sensors.csv"), np.load(folder / "damage.npz"))
    (sf, (tf, names, hf), df), (sc, (tc, names_c, hc), dc) = runs["full"], runs["coupled"]
    if names != names_c:
        raise ValueError(f"sensor names differ: {names} vs {names_c}")
    if sf["spec"]["radius"] != sc["spec"]["radius"]:
        raise ValueError("the two runs have different sphere radii: not the same slab")
    t_end = min(tf[-1], tc[-1])
    t = tf[tf <= t_end]
    sensors = {}
    for i, name in enumerate(names):
        full_z = hf[tf <= t_end, i, 2]
        coupled_z = np.interp(t, tc, hc[:, i, 2])
        peak_f, peak_c = np.abs(full_z).max(), np.abs(coupled_z).max()
        sensors[name] = {
            "peak_full": peak_f, "peak_coupled": peak_c,
            "peak_time_full_s": t[np.argmax(np.abs(full_z))],
            "peak_time_coupled_s": t[np.argmax(np.abs(coupled_z))],
            "peak_ratio": peak_c / peak_f if peak_f > 0 else None,
            "nrms": float(np.sqrt(np.mean((coupled_z - full_z) ** 2)) / peak_f) if peak_f > 0 else None,
        }
    # damage maps: the coupled slab spheres are a subset of the full ones (same packing)
    where = {int(k): j for j, k in enumerate(df["slab_index"])}
    match = np.array([where[int(k)] for k in dc["slab_index"]])
    in_zone = dc["in_de_zone"]
    d_full, d_coupled = df["damage"][-1][match], dc["damage"][-1]
    vol_c = 4.0 / 3.0 * np.pi * dc["radius"] ** 3
    damage = {
        "broken_links_full": sf["damage"]["broken_links"],
        "broken_links_coupled": sc["damage"]["broken_links"],
        "damaged_volume_full_m3": sf["damage"]["damaged_volume_m3"],
        "damaged_volume_coupled_m3": sc["damage"]["damaged_volume_m3"],
        "damage_map_correlation_de_zone": _correlation(d_full[in_zone], d_coupled[in_zone]),
        "damaged_volume_de_zone_full_m3": float(d_full[in_zone] @ vol_c[in_zone]),
        "damaged_volume_de_zone_coupled_m3": float(d_coupled[in_zone] @ vol_c[in_zone]),
    }
    v_f, v_c = damage["damaged_volume_full_m3"], damage["damaged_volume_coupled_m3"]
    damage["damaged_volume_ratio"] = v_c / v_f if v_f > 0 else None
    speedup = sf["s_per_step"] / sc["s_per_step"]
    result = {
        "full": str(full_dir), "coupled": str(coupled_dir), "compared_until_s": t_end,
        "full_elastic_outside": sf["spec"].get("elastic_outside", False),
        "sensors": sensors, "damage": damage,
        "speedup_per_step": speedup,
        "sphere_count_ratio": sf["n_spheres"] / sc["n_spheres"],
        "projected_100k_steps_s": {"full": 1e5 * sf["s_per_step"], "coupled": 1e5 * sc["s_per_step"]},
        "goals": {
            "peaks_within_10_percent": all(s["peak_ratio"] is not None and abs(s["peak_ratio"] - 1) <= 0.10
                                           for s in sensors.values()),
            "history_nrms_at_most_15_percent": all(s["nrms"] is not None and s["nrms"] <= 0.15
                                                   for s in sensors.values()),
            "damaged_volume_within_15_percent": damage["damaged_volume_ratio"] is not None
                                                and abs(damage["damaged_volume_ratio"] - 1) <= 0.15,
        },
    }
    write_json(out / "comparison.json", result)
    _plot_comparison(out, names, (tf, hf), (tc, hc), dc["positions"], d_full, d_coupled, in_zone)
    return result


def _correlation(a, b):
    if a.size < 2 or a.std() == 0 or b.std() == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def _plot_comparison(out, names, full, coupled, positions, d_full, d_coupled, in_zone):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for ax, i, name in zip(axes.ravel(), range(len(names)), names):
        for label, (t, h), style in (("full", full, "-"), ("coupled", coupled, "--")):
            ax.plot(t * 1e3, h[:, i, 2] * 1e3, style, label=label)
        ax.set(title=name, xlabel="time (ms)", ylabel="z displacement (mm)")
        ax.legend()
    fig.tight_layout()
    fig.savefig(out / "histories.png", dpi=120)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    damage_map(axes[0], positions[in_zone], d_full[in_zone], "full: damage in the DE zone")
    damage_map(axes[1], positions[in_zone], d_coupled[in_zone], "coupled: damage in the DE zone")
    fig.tight_layout()
    fig.savefig(out / "damage_maps.png", dpi=120)
    plt.close(fig)
