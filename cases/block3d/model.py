"""The coupled block built through orchestrator.builder, and its weighted energy."""
import numpy as np

from cases.block3d.spec import UniformOverlap, cubic_lattice


class BlockScene:
    """The block's spheres (orchestrator.contracts.DEScene): a dense packing (or a cubic
    lattice) of the box [0, de_hi], of which the model keeps those `keep` holds, with
    elastic CPM links that never damage; `earlier`: as the slab's (cases.slab.model.SlabScene)."""
    time_step = (None, "")

    def __init__(self, spec, earlier=()):
        self.spec, self.earlier, self._packed = spec, list(earlier), None

    def place(self, keep):
        from yade_side import import_yade
        from yade_side.packing import growth_groups, packing_fraction
        from yade_side.scene import reset_scene
        yade, s = import_yade(), self.spec
        centres, radii = self._packing()
        fraction = packing_fraction(radii, np.prod(s.de_hi))
        self.index = (np.arange(len(radii)) if keep is None
                      else np.concatenate(growth_groups(centres, [*self.earlier, keep])))
        reset_scene()
        self.material = yade.Omega().materials.append(yade.wrapper.CpmMat(
            young=s.contact_young, poisson=s.contact_poisson, density=s.density / fraction,
            frictionAngle=0.5, sigmaT=1e30, epsCrackOnset=1e30, relDuctility=1.0,
            neverDamage=True))
        self.ids = self._add(self.index)
        return self.ids

    def extend(self, keep, earlier):
        """The spheres `keep` holds that the scene `earlier` had not placed, added to the
        running scene; returns every sphere's id, earlier's first."""
        from yade_side.packing import added_by
        self._packed = earlier._packed
        added = added_by(keep, self._packing()[0], earlier.index)
        self.material, self.index = earlier.material, np.concatenate([earlier.index, added])
        self.ids = np.concatenate([earlier.ids, self._add(added)])
        return self.ids

    def _packing(self):
        """(centres, radii) of every sphere the block may hold (made once)."""
        from yade_side.packing import dense_box_packing, sphere_arrays
        s = self.spec
        if self._packed is None:
            self._packed = (cubic_lattice(s.de_hi, s.radius) if s.packing == "cubic" else
                            sphere_arrays(dense_box_packing((0, 0, 0), s.de_hi, s.radius)))
        return self._packed

    def _add(self, index):
        from yade_side.packing import add_spheres
        centres, radii = self._packing()
        return add_spheres(centres[index], radii[index], self.material)

    def critical_dt(self, beta):
        from yade import utils
        return utils.PWaveTimeStep()

    def start(self, dt):
        from yade_side import import_yade
        from yade_side.scene import cpm_engines, create_cohesive_links
        yade = import_yade()
        self.law, _ = cpm_engines(dt=dt)
        # YADE's default shear kinematics (avoidGranularRatcheting) takes the lever arms as the
        # radii while the law applies the shear force at the contact point, mid-way in the
        # gap of a distant link: not conservative (measured: 1.9 % energy error on this block
        # alone). Contact-point lever arms make the links conservative (6e-8).
        for engine in yade.Omega().engines:
            if isinstance(engine, yade.wrapper.InteractionLoop):
                engine.geomDispatcher.functors[0].avoidGranularRatcheting = False
        create_cohesive_links()
        return True

    def attach(self, couple):
        return False


class CoupledBlock:
    """The YADE scene, the FE model and the coupling of the block; `stepper` advances both.

    spheres: BodySet of every sphere; bridge: BodySet of the coupled bridging spheres (all
    the bridging spheres except those in `exclude(centres) -> mask`, e.g. spheres whose
    motion is prescribed); fe_partner(fe): the FE partner the coupling sees (default: the
    FE model itself); beta: β of every sphere; de_weight, fe_weight: the weights per sphere
    and per FE dof that the partners do not carry themselves (β and α for the nodal
    weighting, 1 for the consistent one), which the coupling and the energy apply.
    """

    def __init__(self, spec, exclude=None, fe_partner=None):
        from fenicsx_side.mesh import box_mesh
        from fenicsx_side.model import ElasticModel
        from orchestrator.builder import CouplingSpec, Description, assemble
        from orchestrator.coupling.bridging import Bridging, HalfSpaceZone
        from yade_side.bulk import BodySet
        self.spec = s = spec
        L = np.array(s.size)
        if s.uniform_weight is None:
            self.bridging = Bridging(HalfSpaceZone((s.de_length, 0, 0), (1, 0, 0)), s.layers,
                                     s.element)
        else:
            self.bridging = UniformOverlap(s.uniform_weight)

        def fe_model(weight):
            n = np.round((L - s.fe_lo) / s.element).astype(int)
            self.fe = ElasticModel(box_mesh(s.fe_lo, L, n), s.young, s.poisson, s.density,
                                   weight=weight)
            return self.fe if fe_partner is None else fe_partner(self.fe)

        scene = BlockScene(s)
        coupling = CouplingSpec(s.variant, s.relaxation, s.rotations, s.weighting)
        parts = assemble(Description(scene, fe_model, self.bridging, coupling,
                                     dt_safety=s.dt_safety, uncoupled=exclude))
        self.O, self.dt, self.law, self.ids = parts.O, parts.dt, scene.law, parts.ids
        self.stepper, self.coupling = parts.stepper, parts.stepper.coupling
        self.spheres = BodySet(self.ids)
        self.bridge_index, self.bridge = parts.bridge_index, parts.stepper.bridge
        self.beta = self.bridging.beta(self.spheres.ref_pos)
        consistent = s.weighting == "consistent"
        self.de_weight = np.ones(len(self.ids)) if consistent else self.beta
        self.fe_weight = (np.ones(self.fe.ndof) if consistent
                          else np.repeat(self.bridging.alpha(self.fe.nodes), 3))

    def set_velocity_field(self, velocity, rate):
        """Start from rest in the reference configuration with the velocity field `velocity(x)`
        and rotation rate `rate(x)` (its ½ curl) at every sphere and FE node, except the coupled
        bridging spheres, which take k v and h v of the FE field, so that the constraints hold
        from the first step. Velocities are half-step values, as both partners store them."""
        v_fe = velocity(self.fe.nodes).ravel()
        self.fe.v = v_fe
        k, h = self.fe.point_operators(self.bridge.ref_pos)
        vel, angvel = velocity(self.spheres.ref_pos), rate(self.spheres.ref_pos)
        vel[self.bridge_index] = (k @ v_fe).reshape(-1, 3)
        angvel[self.bridge_index] = (h @ v_fe).reshape(-1, 3)
        self.spheres.set_velocity(vel, angvel)


class WeightedEnergy:
    """Energy of the coupled block, H = α H_FE + β H_DE (docs/method.md, eq. 2): FE kinetic and
    strain energy and sphere kinetic and CPM link energy, weighted by the block's fe_weight
    and de_weight (a link weighs the mean of its two spheres'), i.e. by α and β for the nodal
    weighting; the consistent one has the weights inside the partners' masses and stiffnesses.

    Kinetic energies use ½ m v(t−Δt/2)·v(t+Δt/2) with the strain/link energies at t: for a
    linear system this is the quantity that the leap-frog conserves exactly, so what remains
    measures the coupling, not the O((ωΔt)²) oscillation of ½ m v² that a half-step velocity
    would show. Call `before()` just before a step and `after()` just after it: it returns
    H(t) of the time t the step started from.
    """

    def __init__(self, block):
        self.b = block
        ids = block.ids
        index = np.full(ids.max() + 1, -1)
        index[ids] = np.arange(len(ids))
        links = list(block.O.interactions)
        weights = np.array([0.5 * (block.de_weight[index[i.id1]] + block.de_weight[index[i.id2]])
                            for i in links])
        # Σ w U = w₀ U_total + Σ (w − w₀) U over the links whose weight differs from the most
        # common one (w₀ = 1 away from the bridging band): only those are read each time
        values, counts = np.unique(weights, return_counts=True)
        self._w0 = values[np.argmax(counts)]
        other = np.flatnonzero(weights != self._w0)
        self._links = [links[i] for i in other]
        self._excess = weights[other] - self._w0
        self._fe_w_mass = block.fe_weight * block.fe.mass
        s = block.spheres
        self._de_w_mass, self._de_w_inertia = block.de_weight * s.mass, block.de_weight * s.inertia

    def before(self):
        s = self.b.spheres
        s.read()
        self._prev = (self.b.fe.v.copy(), s.vel.copy(), s.angvel.copy(),
                      self.b.fe.strain_energy(self.b.fe_weight))

    def after(self):
        fe, s = self.b.fe, self.b.spheres
        v_fe, vel, angvel, strain = self._prev
        s.read()
        kinetic_fe = 0.5 * float(np.sum(self._fe_w_mass * v_fe * fe.v))
        kinetic_de = 0.5 * float(self._de_w_mass @ np.einsum("ij,ij->i", vel, s.vel)
                                 + self._de_w_inertia @ np.einsum("ij,ij->i", angvel, s.angvel))
        return kinetic_fe + kinetic_de + strain + self.link_energy()

    def link_energy(self):
        """β-weighted CPM link energy at the positions the last step started from (the law's
        forces are those of that configuration)."""
        from yade_side.scene import link_energy
        excess = np.array([link_energy(i.phys) for i in self._links])
        return self._w0 * self.b.law.elasticEnergy() + float(self._excess @ excess)
