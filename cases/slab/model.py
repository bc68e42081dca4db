"""The slab impact (the paper's §5): a concrete cube of spheres hits a simply supported slab.

One description, two models:
- full: the whole slab in spheres (YADE alone);
- coupled: spheres in a central DE zone through the thickness plus a bridging band of
  `layers` FE element layers around it; FE (dolfinx) everywhere outside the DE zone.
Both models take their slab spheres from the same packing of the whole slab, so the DE
zone's micro-structure is the same in both and damage maps compare sphere by sphere.
"""
from dataclasses import asdict
from time import perf_counter

import numpy as np

from cases.slab.packings import make_packings, supported
from cases.slab.reinforced import YIELD_EVERY
from cases.slab.scales import SLAB
from cases.slab.zone import fe_axes, model_grid, sensor_points, slab_bridging
from orchestrator.builder import CouplingSpec, Description, Model, assemble

MODELS = ("full", "coupled")


def concrete(spec):
    """The slab's CPM parameters: the calibrated set of its scale, its bulk density."""
    from yade_side.material import ConcreteParams
    return ConcreteParams(density=spec.density, **spec.cpm)


def fe_weight(spec, grid):
    """α inside the FE model (the consistent weighting), else None."""
    return slab_bridging(spec, grid).alpha if spec.weighting == "consistent" else None


def fe_model(spec, grid, weight):
    """The coupled model's FE part: the slab less the DE zone, its x = 0 and x = 2.5 faces held
    in z (simple supports), with its bars; `weight`: α inside stiffness and mass (or None).
    Collective under MPI: every rank builds it."""
    return fe_parts(spec, grid, weight)[0]


def fe_parts(spec, grid, weight):
    """fe_model's model and its embedded bars (fenicsx_side.bars.EmbeddedBars, or None)."""
    from fenicsx_side.model import ElasticModel, face
    if grid.h_band is not None:
        from fenicsx_side.mesh import tensor_box_with_hole
        msh = tensor_box_with_hole(*fe_axes(grid), grid.hole_lo, grid.hole_hi)
    elif grid.cells is None:
        from fenicsx_side.mesh import box_mesh_with_hole
        msh = box_mesh_with_hole((0, 0, 0), SLAB, grid.n, grid.hole_lo, grid.hole_hi)
    else:
        from fenicsx_side.cells import box_mesh_without_cells
        removed = np.repeat(grid.cells[:, :, None], grid.n[2], axis=2)
        msh = box_mesh_without_cells((0, 0, 0), SLAB, grid.n, removed)
    supports = [(face(0, 0.0), (2,)), (face(0, SLAB[0]), (2,))]
    if spec.fe_material == "damage":
        from fenicsx_side.damage_law import ConcreteDamage
        from fenicsx_side.damaged import DamageModel
        model = DamageModel(msh, ConcreteDamage(**spec.damage_law()), spec.density, supports,
                            weight=weight)
    else:
        model = ElasticModel(msh, spec.young, spec.poisson, spec.density, supports,
                             weight=weight)
    bars = None
    if spec.reinforced:
        if model.comm.size > 1:
            raise ValueError("slab: reinforced under mpirun is not supported (the bars' yield "
                             "checks read the FE state on one rank): run it without mpirun")
        from cases.slab.reinforced import fe_bars, model_bars
        part = model_bars(spec, "coupled", slab_bridging(spec, grid))[1]
        if part is not None:
            bars = fe_bars(model, part, grid.band_h / 2, weight)
    return model, bars


class SlabScene:
    """The YADE scene of the slab (orchestrator.contracts.DEScene): the slab's spheres (all, or
    those a coupled model keeps), the impactor, and for the full model the supports; `packs`:
    the spec's make_packings, if already made (the same for every zone); `earlier`: the keep
    masks of the zones a grown zone went through, in order (a resumed run places the spheres
    in the order the growth added them: the scene it loads numbers them so)."""
    time_step = (None, "")

    def __init__(self, spec, bridging, packs=None, earlier=()):
        self.spec, self.bridging, self.earlier = spec, bridging, list(earlier)
        self.packs = make_packings(spec) if packs is None else packs
        self.elastic_links = 0
        self.fe_bars = None           # the FE part's embedded bars, once it is built

    def place(self, keep):
        from yade_side.material import cpm_material
        from yade_side.packing import add_spheres, growth_groups
        from yade_side.scene import reset_scene
        p = self.packs
        groups = ([np.arange(len(p.slab_radii))] if keep is None
                  else growth_groups(p.slab_centres, [*self.earlier, keep]))
        self.slab_index = np.concatenate(groups)
        reset_scene()
        self.material = mat = cpm_material(concrete(self.spec), p.slab_fraction)
        first = add_spheres(p.slab_centres[groups[0]], p.slab_radii[groups[0]], mat)
        self.impactor_ids = add_spheres(p.impactor_centres, p.impactor_radii, mat)
        later = self.slab_index[len(groups[0]):]
        self.slab_ids = np.concatenate([first, add_spheres(p.slab_centres[later],
                                                           p.slab_radii[later], mat)])
        self.support_ids = np.empty(0, int)
        if keep is None:        # simple supports: spheres touching x = 0 and x = 2.5 hold z
            from yade_side.scene import block_dofs
            self.support_ids = self.slab_ids[supported(p.slab_centres, p.slab_radii)]
            block_dofs(self.support_ids, "z")
        if self.spec.reinforced:
            from yade_side.bars import shield_bars
            shield_bars(self.slab_ids, self.impactor_ids)
        return self.slab_ids

    def extend(self, keep, earlier):
        """The slab's spheres `keep` holds that the scene `earlier` (of the model whose zone
        grew) had not placed, added to the running scene after its bodies; returns the slab's
        ids, earlier's first. The rest (engines, impactor) is earlier's."""
        from yade_side.packing import add_spheres, added_by
        p = self.packs
        added = added_by(keep, p.slab_centres, earlier.slab_index)
        self.__dict__.update({k: getattr(earlier, k) for k in (
            "material", "impactor_ids", "impactor", "support_ids", "elastic_links")})
        self.slab_index = np.concatenate([earlier.slab_index, added])
        self.slab_ids = np.concatenate([earlier.slab_ids, add_spheres(
            p.slab_centres[added], p.slab_radii[added], self.material)])
        return self.slab_ids

    def critical_dt(self, beta):
        from yade import utils
        return utils.PWaveTimeStep()

    def start(self, dt):
        """Engines and links; then the impactor is lowered to just above the slab and set
        moving (it was made beyond the links' reach)."""
        from yade_side.bulk import BodySet
        from yade_side.scene import cpm_engines, create_cohesive_links
        cpm_engines(dt=dt, shear_release=self.spec.shear_release)
        if self.spec.mpi:
            self._split()
        else:
            create_cohesive_links()
        if self.spec.elastic_outside:
            from yade_side.damage import keep_links_elastic
            self.elastic_links = keep_links_elastic(lambda p: self.bridging.zone.depth(p) > 0)
        self.impactor = BodySet(self.impactor_ids)
        self.impactor.move(np.array([0.0, 0.0, -self.packs.impactor_drop]))
        self.impactor.set_velocity(np.array([0.0, 0.0, -self.spec.impactor_speed]))
        return True

    def attach(self, couple):
        return False

    def _split(self):
        """The scene over spec.mpi ranks (yade.mpy): the workers own slices along x of equal
        count; the split's first step makes the links."""
        from mpi4py import MPI
        from yade_side.distributed import RankZeroScene, owners
        if MPI.COMM_WORLD.size != self.spec.mpi:
            raise ValueError(f"slab: mpi = {self.spec.mpi} runs on that many MPI ranks, this "
                             f"process has {MPI.COMM_WORLD.size} (the slab and run commands "
                             f"start mpiexec themselves)")
        p = self.packs
        x = np.concatenate([p.slab_centres[self.slab_index, 0], p.impactor_centres[:, 0]])
        radius = min(p.slab_radii.min(), p.impactor_radii.min())
        RankZeroScene(MPI.COMM_WORLD).split(owners(x, self.spec.mpi - 1), radius)


def check_ranks(spec, model):
    """spec.mpi (YADE's MPI) is for the full model only."""
    if spec.mpi and model != "full":
        raise ValueError(f"slab: mpi = {spec.mpi} runs the full model on YADE's MPI, not the "
                         f"{model} one (its FE runs under mpirun: docs/mpi.md)")


def description(spec, model, grid=None, dt=None, packs=None, earlier=()):
    """The builder's description of the slab's `model` (full or coupled), with the DE zone
    of `grid` (default: the spec's fixed zone, model_grid), and the time step `dt` (default: the
    spec's dt_safety × the critical step); `packs`, `earlier`: SlabScene's."""
    if model not in MODELS:
        raise ValueError(f"model must be 'full' or 'coupled', got {model!r}")
    check_ranks(spec, model)
    if spec.elastic_outside and model != "full":
        raise ValueError("elastic_outside applies to the full model only (the coupled "
                         "model has FE outside its DE zone)")
    grid = model_grid(spec) if grid is None else grid
    bridging = slab_bridging(spec, grid)
    scene = SlabScene(spec, bridging, packs, earlier)

    def coupled_fe(weight):
        from fenicsx_side.distributed import on_rank_zero
        part, scene.fe_bars = fe_parts(spec, grid, weight)
        return on_rank_zero(part)
    fe = coupled_fe if model == "coupled" else None
    coupling = CouplingSpec(spec.variant, spec.relaxation, spec.rotations, spec.weighting)
    bars = None
    if spec.reinforced:
        from cases.slab.reinforced import DEBars, bond, model_bars
        part = model_bars(spec, model, bridging)[0]
        weighted = model == "coupled" and spec.weighting == "consistent"
        if part is not None:
            bars = DEBars(part, spec.radius, bond(spec), bridging.beta if weighted else None)
    return Description(scene, fe, bridging, coupling, dt_safety=spec.dt_safety, dt=dt,
                       dt_source="the time step of the run's first zone", bars=bars), grid


class SlabModel(Model):
    """The slab's full or coupled model, built, with its sensors; with `grown_from` (a
    SlabModel), in its running scene (orchestrator.builder.assemble_grown); `earlier`: see
    SlabScene."""

    def __init__(self, spec, model, grid=None, dt=None, packs=None, grown_from=None,
                 earlier=()):
        t0 = perf_counter()
        d, self.grid = description(spec, model, grid, dt, packs, earlier)
        super().__init__(assemble(d, grown_from))
        self.de_bars, self.bar_ids = d.bars, self.parts.bar_ids
        scene = d.scene
        self.spec, self.model, self.scene = spec, model, scene
        self.slab, self.slab_ids, self.slab_index = self.spheres, scene.slab_ids, scene.slab_index
        self.impactor, self.impactor_ids = scene.impactor, scene.impactor_ids
        self.support_ids, self.elastic_links = scene.support_ids, scene.elastic_links
        self.radius = self.slab.radius
        self.solid_fraction = scene.packs.slab_fraction
        self.initial_links = int(self.damage.initial.sum())
        self.energy_bodies = [self.slab, self.impactor]
        self.yield_watch = None
        if spec.reinforced:
            from cases.slab.reinforced import YieldWatch
            from yade_side.bulk import BodySet
            self.energy_bodies.append(BodySet(self.bar_ids))
            self.yield_watch = YieldWatch(self.de_bars, scene.fe_bars)
        self._sensors()
        self.build_s = perf_counter() - t0

    def step(self):
        super().step()
        if self.yield_watch is not None and self.O.iter % YIELD_EVERY == 0:
            self.yield_watch.check(self.O.time)

    def quantities(self, last=None):
        from cases.slab.quantities import Quantities
        return Quantities(self, last)

    def bar_figures(self):
        """What summary.json records of the bars (None for a plain slab)."""
        if not self.spec.reinforced:
            return None
        de, fe = self.de_bars, self.scene.fe_bars
        return {"layers": len(self.spec.reinforcement),
                "steel_spheres": len(self.bar_ids),
                "chain_links": 0 if de is None else len(de.chains.links),
                "bond_links": 0 if de is None else de.bond_count,
                "bond_strength_Pa": None if de is None else de.bond.strength,
                "slip_stiffness_Pa_m": None if de is None else de.bond.slip_stiffness,
                "de_bar_length_m": 0.0 if de is None else float(de.bars.length.sum()),
                "de_mass_scale": None if de is None else float(de.chains.mass_scale.max()),
                "fe_bar_elements": 0 if fe is None else len(fe.elements),
                "fe_bar_length_m": 0.0 if fe is None else float(fe.length.sum())}

    def _sensors(self):
        """Spheres nearest the sensor points, and the FE node nearest the bridging sensor (in
        the full model, the sphere nearest that node's position: the same grid in both)."""
        points = sensor_points(self.spec, self.grid)
        pos = self.slab.ref_pos
        idx = [int(np.argmin(np.linalg.norm(pos - p, axis=1))) for p in points.values()]
        node_point = self._fe_node_position(pos[idx[-1]])
        nodes = []
        if self.fe is not None:
            nodes = [int(np.argmin(np.linalg.norm(self.fe.nodes - node_point, axis=1)))]
        else:
            idx.append(int(np.argmin(np.linalg.norm(pos - node_point, axis=1))))
        self.set_sensors(list(points) + ["fe_node"], idx, nodes, np.vstack([pos[idx], node_point]))

    def _fe_node_position(self, x):
        """Nearest node of the FE grid (the structured grid of both models)."""
        if self.grid.h_band is not None:
            return np.array([a[np.argmin(np.abs(a - c))] for a, c in zip(fe_axes(self.grid), x)])
        h, hz = self.grid.h, SLAB[2] / self.grid.n[2]
        return np.array([round(x[0] / h) * h, round(x[1] / h) * h, round(x[2] / hz) * hz])


def run(spec, model, out, quiet=False, resume=False, start=None, inputs=None):
    """Run one model of `spec` with its box zone to spec.steps and write its results folder
    `out`, or carry on from its checkpoint (resume). `start()`, if given, makes the folder once
    the model is built (and returns it); `inputs`: what the results depend on
    (orchestrator.run.inputs), a resumed run must have the same."""
    m = SlabModel(spec, model)
    if start is not None:
        out = start()
    return run_built(m, out, quiet, resume, inputs)


def run_built(m, out, quiet=False, resume=False, inputs=None):
    """Run the built slab model `m` to its spec.steps into the folder `out`."""
    from cases.slab.quantities import split_unmeasured
    from orchestrator.run.inputs import spec_inputs
    from orchestrator.run.loop import Schedule, run as run_loop
    spec, model = m.spec, m.model
    impact_energy = 0.5 * m.impactor.mass.sum() * spec.impactor_speed**2
    bars = m.bar_figures()          # the checks add the bars' yield figures at the end
    info = {"model": model, "seed": spec.seed, "spec": asdict(spec),
            "cpm": asdict(concrete(spec)), "n_slab_spheres": len(m.slab_ids),
            "build_s": m.build_s, "impact_energy_J": impact_energy,
            "links_kept_elastic": m.elastic_links, "reinforcement": bars}
    if m.grid.cells is not None:
        info["zone_cells"] = np.argwhere(m.grid.cells).tolist()
    schedule = Schedule(spec.steps, spec.sample_every, spec.check_every, spec.output_every,
                        spec.checkpoint_every)
    unmeasured = spec.energy_split and split_unmeasured(m)
    notes = [f"no energy split is recorded: {unmeasured}"] if unmeasured else []
    return run_loop(m, schedule, out, f"slab {model} ({spec.scale})", impact_energy,
                    info=info, arrays=lambda: {"slab_index": m.slab_index}, notes=notes,
                    checks=lambda damage, peak: _post_run_checks(m, damage, peak, info, bars),
                    quiet=quiet, resume=resume,
                    inputs=spec_inputs(spec, model) if inputs is None else inputs)


def _post_run_checks(m, damage, fe_peak, info, bars=None):
    """The paper's two checks: the FE stays elastic; the bridging spheres stay undamaged. For
    the full model, their counterpart: links where the coupled model has its band and FE that
    passed their tensile strength (ω > 0), which an elastic FE there cannot follow; and
    info["links_outside_de_zone"]: how many links are damaged there (cases.slab.variants)."""
    from orchestrator.run.checks import post_run_checks
    from orchestrator.run.outputs import fe_damage
    spec = m.spec
    warnings = post_run_checks(fe_peak, damage[m.bridge_index], spec.tensile_strength,
                               spec.compressive_strength,
                               fe_damage(m) if m.fe_damages else None, spec.trip_damage)
    if fe_peak is not None and not m.fe_damages and \
            fe_peak["max_principal_Pa"] > spec.tensile_strength:
        warnings.append(f"the elastic FE went {fe_peak['max_principal_Pa'] / spec.tensile_strength:.2f} "
                        f"× past ft: run with --fe-material damage (fe.material = \"damage\"), "
                        f"an FE that cracks where the concrete does (docs/fe-damage.md)")
    if m.yield_watch is not None:
        warnings += m.yield_watch.warnings()
        bars.update(m.yield_watch.figures())
    if m.fe is None:
        from cases.slab.links import link_record
        pairs, omega = m.damage.link_omega()
        slab_links = (pairs >= 0).all(axis=1)       # links between two slab spheres
        pairs, omega = pairs[slab_links], omega[slab_links]
        ref = m.slab.ref_pos
        outside = m.bridging.zone.depth(0.5 * (ref[pairs[:, 0]] + ref[pairs[:, 1]])) > 0
        info["links_outside_de_zone"] = link_record(omega, outside)
        cracked = np.count_nonzero(omega[outside] > 0)
        if cracked and not m.spec.elastic_outside:
            warnings.append(f"{cracked} of the {np.count_nonzero(outside)} links outside the "
                            f"coupled model's DE zone are damaged (mean ω "
                            f"{omega[outside].mean():.3f}, broken ones counting as 1): a "
                            f"coupled model with an elastic FE there will be stiffer "
                            f"(docs/slab.md), one with --fe-material damage can follow "
                            f"them (docs/fe-damage.md)")
    return warnings
