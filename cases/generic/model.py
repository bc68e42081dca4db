"""A generic coupled case built from a checked case file (cases.generic.schema): its DE scene
(cases.generic.scenes), its FE mesh (a box with the DE zone cut out, or a gmsh file) and a box
DE zone through the structure along the axes not in `zone_axes`, with `layers` bridging
layers; built by orchestrator.builder, which checks what needs both models before the first
step (spheres in the band, each in an FE cell, the time step). Every problem found goes into
one CaseError."""
import numpy as np

from cases.generic import checks
from cases.generic.scenes import PackingScene, UserScriptScene
from orchestrator.builder import BuildError, CouplingSpec, Description, Model, assemble
from orchestrator.casefile import AXIS, CaseError
from orchestrator.coupling.bridging import BoxZone, Bridging


class CaseModel(Model):
    def __init__(self, case):
        self.case = case
        self.warnings = []           # set-up warnings: printed, and in the notes
        d = case.data
        cp, time = d["coupling"], d["time"]
        self.bridging = Bridging(BoxZone(cp["zone_lo"], cp["zone_hi"], cp["zone_axes"]),
                                 cp["layers"], cp["element_size"])
        scripted = "script" in d["de"] or d["de"]["current"]
        scene = (UserScriptScene(d["de"], self.bridging) if scripted
                 else PackingScene(d["de"]["packing"], d["material"]))
        coupling = CouplingSpec(cp["variant"], cp["relaxation"], cp["rotations"], cp["weighting"])
        description = Description(scene, self._fe_model, self.bridging, coupling,
                                  dt_safety=time["dt_safety"], dt=time.get("dt"),
                                  dt_source="time.dt")
        try:
            super().__init__(assemble(description))
        except BuildError as e:
            raise CaseError(case.path, e.problems) from None
        self.notes = scene.notes + self.notes
        self.reference_energy = scene.reference_energy
        problems = []
        checks.band_filled(self.bridging, self.spheres.ref_pos, self.spheres.radius, problems)
        self.run_steps = checks.steps(time, self.dt, problems, self.notes)
        self._sensors(d["sensors"], problems)
        if problems:
            raise CaseError(case.path, problems)
        self.notes += [f"warning: {w}" for w in self.warnings]

    def _fe_model(self, weight):
        """The FE partner: its mesh must hold the DE zone and leave it out."""
        from fenicsx_side.model import ElasticModel
        fe, mat, zone = self.case["fe"], self.case["material"], self.bridging.zone
        msh = _mesh(fe, zone)
        x = msh.geometry.x
        lo, hi = x.min(axis=0), x.max(axis=0)
        problems = [f"coupling.{bound}[{a}] = {z[a]!r}: the DE zone is outside the mesh, which "
                    f"spans [{lo[a]:g}, {hi[a]:g}] along axis {a}"
                    for bound in ("zone_lo", "zone_hi")
                    for z in [np.array(self.case["coupling"][bound])]
                    for a in zone.axes if not lo[a] <= z[a] <= hi[a]]
        if problems:
            raise CaseError(self.case.path, problems)
        n_cells = msh.topology.index_map(msh.topology.dim).size_local
        cells = msh.geometry.dofmap.array.reshape(n_cells, -1)    # P1 geometry: the vertices
        inside = np.count_nonzero(zone.depth(x[cells].mean(axis=1)) < 0)
        if inside:
            raise CaseError(self.case.path, [
                f"fe.mesh: {inside} elements lie inside the DE zone; the FE mesh must leave the "
                f"DE zone out (only the bridging layers overlap the spheres)"])
        # the band's width is layers × element_size: that size first, then the band's room
        checks.element_size(self.bridging.width / self.bridging.layers,
                            checks.measured_element_size(self.bridging, x, cells),
                            problems, self.warnings)
        if not problems:
            checks.band_in_mesh(self.bridging, lo, hi, self.case["coupling"]["layers"], problems)
        if problems:
            raise CaseError(self.case.path, problems)
        try:
            return ElasticModel(msh, mat["young"], mat["poisson"], mat["density"],
                                _supports(fe["dirichlet"], lo, hi), weight=weight)
        except ValueError as e:
            raise CaseError(self.case.path, [f"fe: {e}"]) from None

    def _sensors(self, sensors, problems):
        """Each sensor on the sphere or FE node nearest its point (or on a sphere by id)."""
        pos = self.spheres.ref_pos
        size = self.bridging.width / self.bridging.layers
        fe_bound = checks.fe_snap_bound(size, self.fe.nodes, self.fe.cell_nodes)
        sphere_rows, node_rows = [], []           # (sensor index, sphere index / FE node)
        index = {int(i): j for j, i in enumerate(self.spheres.ids)}
        for k, s in enumerate(sensors):
            if "sphere" in s:
                if s["sphere"] not in index:
                    problems.append(f"sensors[{k}].sphere = {s['sphere']}: no coupled sphere has "
                                    f"this id")
                    continue
                sphere_rows.append((k, index[s["sphere"]]))
                continue
            p = np.array(s["point"])
            on = s["on"]
            where = ""
            if on == "auto":
                on = "de" if self.bridging.covers(p)[0] else "fe"
                if self.bridging.contains(p)[0]:
                    where = " (on = 'auto' in the bridging domain; on = 'fe' for the FE node)"
            if on == "de":
                j = int(np.argmin(np.linalg.norm(pos - p, axis=1)))
                sphere_rows.append((k, j))
                checks.snapped(k, s, "sphere", f"{self.spheres.ids[j]}{where}",
                               float(np.linalg.norm(pos[j] - p)), (size, "the element size"),
                               problems, self.notes)
            else:
                n = int(np.argmin(np.linalg.norm(self.fe.nodes - p, axis=1)))
                node_rows.append((k, n))
                checks.snapped(k, s, "FE node", str(n),
                               float(np.linalg.norm(self.fe.nodes[n] - p)), (fe_bound, "the element size or half the largest cell diagonal"),
                               problems, self.notes)
        spheres, nodes = [j for _, j in sphere_rows], [n for _, n in node_rows]
        self.set_sensors([sensors[k]["name"] for k, _ in sphere_rows + node_rows], spheres, nodes,
                         np.vstack([pos[spheres], self.fe.nodes[nodes]]))


def _mesh(fe, zone):
    from fenicsx_side.mesh import box_mesh_with_hole, read_msh
    if fe["mesh"] != "box":
        return read_msh(fe["mesh"])
    lo, hi = np.array(fe["lo"]), np.array(fe["hi"])
    hole_lo, hole_hi = lo.copy(), hi.copy()
    hole_lo[zone.axes], hole_hi[zone.axes] = zone.lo[zone.axes], zone.hi[zone.axes]
    return box_mesh_with_hole(lo, hi, fe["n"], hole_lo, hole_hi, fe["cell"])


def _supports(dirichlet, lo, hi):
    """(selector, components) of each [[fe.dirichlet]] face, a plane of the mesh's box."""
    from fenicsx_side.model import face
    supports = []
    for c in dirichlet:
        axis = AXIS[c["face"][0]]
        plane = lo[axis] if c["face"].endswith("min") else hi[axis]
        supports.append((face(axis, plane), tuple(AXIS[k] for k in c["components"])))
    return supports


def run(case, out, force=False, quiet=False, resume=False):
    """Build and run a checked generic case into the results folder `out`; returns the
    summary. The model is built, and every problem reported, before the folder is made."""
    import sys
    from time import perf_counter
    from orchestrator.run.checks import post_run_checks
    from orchestrator.run.folder import start_folder
    from orchestrator.run.inputs import case_inputs
    from orchestrator.run.loop import Schedule, run as run_loop
    t0 = perf_counter()
    model = CaseModel(case)            # raises CaseError before anything runs
    build_s = perf_counter() - t0
    for w in model.warnings:
        print(f"WARNING: {w}", file=sys.stderr)
    if not resume:
        out = start_folder(case, out, force)
    d, mat, o = case.data, case["material"], case["output"]
    info = {"case": d["case"]["name"], "kind": case.kind, "build_s": build_s,
            "relaxation": model.relaxation, "variant": d["coupling"]["variant"],
            "weighting": d["coupling"]["weighting"], "rotations": d["coupling"]["rotations"],
            "notes": model.notes, "reference_energy_J": model.reference_energy}
    schedule = Schedule(model.run_steps, o["sample_every"], o["check_every"], o["every"],
                        o["checkpoint_every"])
    def checks(damage, peak):
        return post_run_checks(peak, damage[model.bridge_index], mat["tensile_strength"],
                               mat["compressive_strength"])
    return run_loop(model, schedule, out, d["case"]["name"], model.reference_energy,
                    info=info, checks=checks, quiet=quiet, notes=model.notes, resume=resume,
                    inputs=case_inputs(case))
