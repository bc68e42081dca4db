"""A generic coupled case built from a checked case file (orchestrator.casefile).

DE side: built-in dense packings of boxes (CPM concrete; spheres beyond the bridging domain
are left out, the FE model is there), or a user's YADE script (yade_side.user_script).
FE side: a box mesh with the DE zone cut out, or a gmsh mesh. Coupling: a box DE zone
through the structure along the axes not in `zone_axes`, `layers` bridging layers.

The coupling step is a PyRunner right after the script's NewtonIntegrator (see
yade_side.user_script): a step of this model is one `O.step()`.

Before the first step the model checks what needs both models: the DE zone inside the mesh,
the mesh leaving the DE zone out, bridging spheres that no FE element contains (or that are
clumps, not spheres, not dynamic), the time step against both critical steps, sensors; every
problem goes into one CaseError.
"""
import math
from time import perf_counter

import numpy as np

from orchestrator.casefile import AXIS, CaseError


def auto_relaxation(ratio, layers, variant, dt_safety):
    """r for relaxation = "auto": the rule fitted on the 1D study (cases.wave1d) from the
    discretisation ratio (FE element size / sphere diameter), n_b, the solver and Δt / the
    critical step; without that module, the paper's advice r ≈ 10 × the ratio."""
    try:
        from cases.wave1d import auto_relaxation as rule
    except ImportError:
        return 10.0 * ratio
    return float(rule(ratio, layers, variant, dt_safety))


class CaseModel:
    def __init__(self, case):
        from orchestrator.assembly import make_coupling
        from orchestrator.bridging import BoxZone, Bridging
        from orchestrator.timeloop import CoupledStepper
        from yade_side import import_yade
        from yade_side.bulk import BodySet
        from yade_side.damage import LinkDamage
        from yade_side.user_script import insert_after_newton

        yade = import_yade()
        self.O = O = yade.Omega()
        self.case = case
        d = case.data
        cp, mat = d["coupling"], d["material"]
        problems = []
        self.notes = []
        self.bridging = Bridging(BoxZone(cp["zone_lo"], cp["zone_hi"], cp["zone_axes"]),
                                 cp["layers"], cp["element_size"])
        self.fe = self._fe_model(d["fe"], mat, problems)
        if problems:
            raise CaseError(case.path, problems)
        if "script" in d["de"]:
            ids, self.reference_energy = self._script_scene(d["de"])
        else:
            ids, self.reference_energy = self._packing_scene(d["de"]["packing"], mat, d["time"])
        if len(ids) == 0:
            raise CaseError(case.path, ["de: no sphere lies in the DE zone or the bridging domain"])
        self.spheres = BodySet(ids)
        depth = self.bridging.zone.depth(self.spheres.ref_pos)
        self.in_de_zone = depth < 0
        self.bridge_index = np.flatnonzero(self.bridging.contains(self.spheres.ref_pos))
        if self.bridge_index.size == 0:
            problems.append(f"coupling: no sphere lies in the bridging domain (zone "
                            f"{cp['zone_lo']}–{cp['zone_hi']}, width {self.bridging.width:g} m)")
        else:
            self._check_located(self.spheres.ref_pos[self.bridge_index], problems)
        self.dt = self._time_step(d["time"], problems)
        self._sensors(d["sensors"], problems)
        if problems:
            raise CaseError(case.path, problems)

        O.dt = self.dt
        self.bridge = BodySet(ids[self.bridge_index])
        if cp["relaxation"] == "auto":
            ratio = cp["element_size"] / (2 * self.bridge.radius.mean())
            safety = self.dt / min(self.critical.values())
            self.relaxation = auto_relaxation(ratio, cp["layers"], cp["variant"], safety)
            self.notes.append(f"relaxation auto: r = {self.relaxation:.4g} for a discretisation "
                              f"ratio {ratio:.3g} (element size / mean sphere diameter), "
                              f"{cp['layers']} layers, {cp['variant']} solver, dt = "
                              f"{safety:.3g} × the critical step")
        else:
            self.relaxation = cp["relaxation"]
        coupling = make_coupling(self.fe, self.bridging, self.bridge, self.dt, cp["variant"],
                                 self.relaxation, cp["rotations"])
        self.stepper = CoupledStepper(O.step, self.bridge, self.fe, coupling)
        insert_after_newton(self.stepper.couple)
        self.damage = LinkDamage(ids)
        self._links_recorded = O.iter > 0
        if self._links_recorded:
            self.damage.record_initial()
        self._step_seconds = 0.0

    # --- building --------------------------------------------------------------------------
    def _fe_model(self, fe, mat, problems):
        from fenicsx_side.mesh import box_mesh_with_hole, read_msh
        from fenicsx_side.model import ElasticModel, face
        zone = self.bridging.zone
        if fe["mesh"] == "box":
            lo, hi = np.array(fe["lo"]), np.array(fe["hi"])
            hole_lo, hole_hi = lo.copy(), hi.copy()
            hole_lo[zone.axes], hole_hi[zone.axes] = zone.lo[zone.axes], zone.hi[zone.axes]
            msh = box_mesh_with_hole(lo, hi, fe["n"], hole_lo, hole_hi, fe["cell"])
        else:
            msh = read_msh(fe["mesh"])
        x = msh.geometry.x
        lo, hi = x.min(axis=0), x.max(axis=0)
        for bound in ("zone_lo", "zone_hi"):
            z = np.array(self.case["coupling"][bound])
            for a in zone.axes:
                if not lo[a] <= z[a] <= hi[a]:
                    problems.append(f"coupling.{bound}[{a}] = {z[a]!r}: the DE zone is outside "
                                    f"the mesh, which spans [{lo[a]:g}, {hi[a]:g}] along axis {a}")
        if problems:
            return None
        supports = []
        for c in fe["dirichlet"]:          # faces are planes of the mesh's bounding box
            axis = AXIS[c["face"][0]]
            plane = lo[axis] if c["face"].endswith("min") else hi[axis]
            supports.append((face(axis, plane), tuple(AXIS[k] for k in c["components"])))
        try:
            model = ElasticModel(msh, mat["young"], mat["poisson"], mat["density"], supports)
        except ValueError as e:
            problems.append(f"fe: {e}")
            return None
        centres = model.nodes[model.cell_nodes].mean(axis=1)
        inside = np.count_nonzero(zone.depth(centres) < 0)
        if inside:
            problems.append(f"fe.mesh: {inside} elements lie inside the DE zone; the FE mesh must "
                            f"leave the DE zone out (only the bridging layers overlap the spheres)")
        return model

    def _packing_scene(self, boxes, mat, time):
        from yade_side.material import ConcreteParams, cpm_material
        from yade_side.packing import add_spheres, dense_box_packing, packing_fraction, sphere_arrays
        from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene
        from yade_side.bulk import BodySet
        reset_scene()
        params = ConcreteParams(density=mat["density"], **mat["cpm"])
        groups = []
        for box in boxes:
            centres, radii = sphere_arrays(dense_box_packing(box["lo"], box["hi"], box["radius"],
                                                             seed=box["seed"]))
            fraction = packing_fraction(radii, np.prod(np.subtract(box["hi"], box["lo"])))
            keep = self.bridging.zone.depth(centres) <= self.bridging.width
            material = cpm_material(params, fraction)
            groups.append((add_spheres(centres[keep], radii[keep], material), box["velocity"]))
        cpm_engines(dt_safety=time["dt_safety"])
        create_cohesive_links()
        energy = 0.0
        for ids, velocity in groups:
            if len(ids) and any(velocity):
                body = BodySet(ids)
                body.set_velocity(np.array(velocity))
                energy += body.kinetic_energy()
        return np.concatenate([g[0] for g in groups]), energy

    def _script_scene(self, de):
        from yade_side.bulk import BodySet
        from yade_side.user_script import ScriptRefused, body_table, prepare_dynamics, run_script
        self.script = run_script(de["script"], de["script_args"])
        prepare_dynamics(self.script)
        self.notes += self.script.warnings
        bodies = body_table()
        in_bridging = self.bridging.contains(bodies["pos"])
        name = self.script.path.name
        for mask, what in ((bodies["clump"], "clumps or clump members"),
                           (np.isnan(bodies["radius"]), "not spheres"),
                           (~bodies["dynamic"], "not dynamic (fixed)")):
            bad = bodies["ids"][in_bridging & mask]
            if bad.size:
                raise ScriptRefused(f"{name}: {bad.size} bodies in the bridging domain are {what} "
                                    f"(ids {bad[:5].tolist()}...); only free spheres can be coupled")
        keep = ~np.isnan(bodies["radius"]) & ~bodies["clump"] & bodies["dynamic"]
        beyond = keep & (self.bridging.zone.depth(bodies["pos"]) > self.bridging.width)
        if beyond.any():
            self.notes.append(f"{name}: {beyond.sum()} spheres lie beyond the bridging domain, "
                              f"where the FE model is: they are not coupled and the structure "
                              f"is modelled twice there")
        ids = bodies["ids"][keep]
        energy = BodySet(ids).kinetic_energy() if ids.size else 0.0
        return ids, energy

    def _check_located(self, points, problems):
        try:
            self.fe.locate(points)
        except ValueError as e:       # it names the first sphere outside and counts them
            problems.append(f"coupling: bridging spheres in no FE element: {e}; the mesh must "
                            f"cover the bridging domain (coupling.zone_lo, zone_hi, layers, "
                            f"element_size)")

    def _time_step(self, time, problems):
        from yade import utils
        de_critical = utils.PWaveTimeStep()
        fe_critical = self.fe.critical_dt()
        self.critical = {"de": de_critical, "fe": fe_critical}
        script_dt = getattr(getattr(self, "script", None), "dt_from_script", None)
        if "dt" in time:
            dt, key = time["dt"], "time.dt"
        elif script_dt is not None:
            dt, key = script_dt, f"O.dt set by {self.script.path.name}"
        else:
            dt, key = time["dt_safety"] * min(de_critical, fe_critical), None
        for name, value in (("DE", de_critical), ("FE", fe_critical)):
            if key and dt > value:
                problems.append(f"{key} = {dt:.4g} s: above the {name} critical step "
                                f"{value:.4g} s (the run would blow up)")
        self.steps = time["steps"] if "steps" in time else max(1, math.ceil(time["duration"] / dt))
        return dt

    def _sensors(self, sensors, problems):
        from yade_side.bulk import BodySet
        pos = self.spheres.ref_pos
        self.sensor_names, self.sensor_positions = [], []
        sphere_rows, node_rows = [], []           # (sensor index, sphere index / FE node)
        index = {int(i): j for j, i in enumerate(self.spheres.ids)}
        for k, s in enumerate(sensors):
            if "sphere" in s:
                if s["sphere"] not in index:
                    problems.append(f"sensors[{k}].sphere = {s['sphere']}: no coupled sphere has "
                                    f"this id")
                    continue
                sphere_rows.append((k, index[s["sphere"]]))
            else:
                p = np.array(s["point"])
                on = s["on"]
                if on == "auto":
                    on = "de" if self.bridging.zone.depth(p)[0] <= self.bridging.width else "fe"
                if on == "de":
                    sphere_rows.append((k, int(np.argmin(np.linalg.norm(pos - p, axis=1)))))
                else:
                    node_rows.append((k, int(np.argmin(np.linalg.norm(self.fe.nodes - p, axis=1)))))
        self._sensor_order = [k for k, _ in sphere_rows] + [k for k, _ in node_rows]
        self._sensor_spheres = BodySet(self.spheres.ids[[j for _, j in sphere_rows]])
        self._sensor_nodes = np.array([n for _, n in node_rows], int)
        self.sensor_names = [sensors[k]["name"] for k in self._sensor_order]
        self.sensor_positions = np.vstack([pos[[j for _, j in sphere_rows]],
                                           self.fe.nodes[self._sensor_nodes]]).reshape(-1, 3)

    # --- the runner's interface --------------------------------------------------------------
    @property
    def seconds(self):
        s = dict(self.stepper.seconds)
        s["yade"] = self._step_seconds - s["fe"] - s["coupling"]   # the PyRunner is inside O.step
        return s

    def step(self):
        t0 = perf_counter()
        self.O.step()
        self._step_seconds += perf_counter() - t0
        if not self._links_recorded:          # the script's scene made its links in this step
            self.damage.record_initial()
            self._links_recorded = True

    def sensor_displacements(self):
        d = np.empty((0, 3))
        if len(self._sensor_spheres):
            self._sensor_spheres.read()
            d = self._sensor_spheres.displacement()
        u = self.fe.u.reshape(-1, 3)[self._sensor_nodes]
        return np.vstack([d, u])

    def energy(self):
        """Kinetic (spheres, FE) + CPM elastic + FE strain energy (the bridging overlap counted
        by both: a blow-up diagnostic, not a balance); CPM's NaN elastic energy is left out."""
        self.spheres.read()
        e = self.spheres.kinetic_energy() + self.fe.kinetic_energy() + self.fe.strain_energy()
        from yade_side.scene import cpm_law
        law = cpm_law()  # looked up each time: a loaded checkpoint replaces the engines
        elastic = law.elasticEnergy() if law is not None else 0.0
        return e + elastic if np.isfinite(elastic) else e

    def sphere_count(self):
        return len(self.spheres)


def run_case(case, out, force=False, quiet=False, threads=None, resume=False):
    """Build and run a checked case into the results folder `out`; returns the summary.
    The folder gets `case.toml`: the case as run (defaults filled in, --set applied, paths
    absolute), which runs again as it is. resume: carry on from the checkpoint in `out`
    (which holds that case.toml)."""
    from orchestrator import runner
    from orchestrator.results import prepare_out
    from yade_side import import_yade
    import_yade(threads)
    t0 = perf_counter()
    if case.kind == "slab":
        from cases import slab
        spec = slab_spec(case)
        if not resume:
            out = prepare_out(out, force)
            _write_case(case, out)
        return slab.run(spec, case["slab"]["model"], out, quiet=quiet, resume=resume)
    if case.kind == "wave1d":
        if resume:
            raise ValueError("a wave1d case is short and has no checkpoints: run it again")
        return _run_wave1d(case, out, force)
    model = CaseModel(case)            # raises CaseError before anything runs
    build_s = perf_counter() - t0
    if not resume:
        out = prepare_out(out, force)
        _write_case(case, out)
    d, mat = case.data, case["material"]
    info = {"case": d["case"]["name"], "kind": case.kind, "build_s": build_s,
            "relaxation": model.relaxation, "variant": d["coupling"]["variant"],
            "rotations": d["coupling"]["rotations"], "notes": model.notes,
            "reference_energy_J": model.reference_energy}
    out_schedule = d["output"]
    schedule = runner.Schedule(model.steps, out_schedule["sample_every"],
                               out_schedule["check_every"], out_schedule["every"],
                               out_schedule["checkpoint_every"])
    checks = lambda damage: runner.post_run_checks(model.fe, damage[model.bridge_index],
                                                   mat["tensile_strength"],
                                                   mat["compressive_strength"])
    return runner.run(model, model.spheres, schedule, out, d["case"]["name"],
                      model.reference_energy, info=info, checks=checks, quiet=quiet,
                      notes=model.notes, resume=resume)


def _run_wave1d(case, out, force):
    """The `wave1d` command with the case file's keys as its options (it writes its own
    results folder)."""
    import json
    from orchestrator.cli import build_parser
    keys = {"--layers": case["coupling"].get("layers"), "--variant": case["coupling"].get("variant"),
            "--relaxation": case["coupling"].get("relaxation"),
            "--ratio": case["wave1d"].get("ratio"), "--dt-safety": case["time"].get("dt_safety")}
    argv = ["wave1d", "--out", str(out)] + (["--force"] if force else [])
    argv += [item for option, value in keys.items() if value is not None
             for item in (option, str(value))]
    args = build_parser().parse_args(argv)
    args.func(args)
    _write_case(case, out)
    return json.loads((out / "summary.json").read_text())


def _write_case(case, out):
    import tomli_w
    from orchestrator.results import write_atomic
    write_atomic(out / "case.toml", f"# the case as run, from {case.path.resolve()}\n"
                 + tomli_w.dumps(case.data))


def slab_spec(case):
    """cases.slab.SlabSpec of a `slab` case file (unset keys keep SlabSpec's defaults)."""
    from cases import slab
    d = case.data
    fields = {k: v for k, v in d["slab"].items() if k != "model"}
    fields.update(d["material"])
    fields.update(d["time"])
    fields.update(d["coupling"])   # relaxation "auto": SlabSpec applies the 1D study's rule
    fields.update({{"every": "output_every"}.get(k, k): v for k, v in d["output"].items()})
    return slab.SlabSpec(**fields)
