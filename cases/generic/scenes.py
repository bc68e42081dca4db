"""The DE scenes of generic case files (orchestrator.contracts.DEScene): built-in dense
packings of boxes with CPM concrete, or a user's YADE script. In both, the coupling runs in
YADE's engine list, right after the NewtonIntegrator (yade_side.user_script)."""
import numpy as np


class PackingScene:
    """[[de.packing]] boxes of CPM concrete; spheres beyond the bridging domain are left out
    (the FE model is there). Each box may start with a velocity."""
    time_step = (None, "")

    def __init__(self, boxes, material):
        self.boxes, self.material = boxes, material
        self.notes, self.reference_energy = [], 0.0

    def place(self, keep):
        from yade_side.material import ConcreteParams, cpm_material
        from yade_side.packing import add_spheres, dense_box_packing, packing_fraction, sphere_arrays
        from yade_side.scene import reset_scene
        reset_scene()
        params = ConcreteParams(density=self.material["density"], **self.material["cpm"])
        self.groups = []
        for box in self.boxes:
            centres, radii = sphere_arrays(dense_box_packing(box["lo"], box["hi"], box["radius"],
                                                             seed=box["seed"]))
            fraction = packing_fraction(radii, np.prod(np.subtract(box["hi"], box["lo"])))
            kept = keep(centres)
            ids = add_spheres(centres[kept], radii[kept], cpm_material(params, fraction))
            self.groups.append((ids, box["velocity"]))
        return np.concatenate([ids for ids, _ in self.groups])

    def critical_dt(self, beta):
        from yade import utils
        return utils.PWaveTimeStep()

    def start(self, dt):
        from yade_side.bulk import BodySet
        from yade_side.scene import cpm_engines, create_cohesive_links
        cpm_engines(dt=dt)
        create_cohesive_links()
        for ids, velocity in self.groups:
            if len(ids) and any(velocity):
                body = BodySet(ids)
                body.set_velocity(np.array(velocity))
                self.reference_energy += body.kinetic_energy()
        return True

    def attach(self, couple):
        from yade_side.user_script import insert_after_newton
        insert_after_newton(couple)
        return True


class UserScriptScene:
    """A user's YADE script, run unchanged (or, with de.current, the scene a script running
    under YADE's own launcher has built: cli.attach); its free spheres are the
    model's. Clumps, other shapes and fixed bodies cannot be coupled and are refused in the
    bridging domain."""

    def __init__(self, de, bridging):
        self.de, self.bridging = de, bridging
        self.notes, self.reference_energy = [], 0.0
        self.time_step = (None, "")

    def place(self, keep):
        from yade_side.bulk import BodySet
        from yade_side.user_script import body_table, current_scene, prepare_dynamics, run_script
        self.script = (current_scene() if self.de["current"]
                       else run_script(self.de["script"], self.de["script_args"]))
        prepare_dynamics(self.script)
        self.notes += self.script.warnings
        name = self.script.path.name
        if self.script.dt_from_script is not None:
            self.time_step = (self.script.dt_from_script, f"O.dt set by {name}")
        bodies = body_table()
        self._refuse_uncouplable(bodies, name)
        free = ~np.isnan(bodies["radius"]) & ~bodies["clump"] & bodies["dynamic"]
        beyond = free & ~keep(bodies["pos"])
        if beyond.any():
            self.notes.append(f"{name}: {beyond.sum()} spheres lie beyond the bridging domain, "
                              f"where the FE model is: they are not coupled and the structure "
                              f"is modelled twice there")
        ids = bodies["ids"][free]
        self.reference_energy = BodySet(ids).kinetic_energy() if ids.size else 0.0
        return ids

    def _refuse_uncouplable(self, bodies, name):
        from yade_side.user_script import ScriptRefused
        in_bridging = self.bridging.contains(bodies["pos"])
        for mask, what in ((bodies["clump"], "clumps or clump members"),
                           (np.isnan(bodies["radius"]), "not spheres"),
                           (~bodies["dynamic"], "not dynamic (fixed)")):
            bad = bodies["ids"][in_bridging & mask]
            if bad.size:
                raise ScriptRefused(f"{name}: {bad.size} bodies in the bridging domain are {what} "
                                    f"(ids {bad[:5].tolist()}...); only free spheres can be coupled")

    def critical_dt(self, beta):
        from yade import utils
        return utils.PWaveTimeStep()

    def start(self, dt):
        """The script's engines stay; its links exist if it has stepped already."""
        from yade_side import import_yade
        O = import_yade().Omega()
        O.dt = dt
        return O.iter > 0

    def attach(self, couple):
        from yade_side.user_script import insert_after_newton
        insert_after_newton(couple)
        return True
