"""A coupled 3D elastic block: YADE spheres with elastic CPM links (never damaged) on
x < x_i + w, a dolfinx FE block on x > x_i, and a bridging band of `layers` FE element
layers (width w) between them, where both models exist (orchestrator.bridging.HalfSpaceZone).

Used by the exact coupled tests (free vibration, rigid motions) and by the paper's 3D check
(`python3 -m orchestrator block3d`): the block is slowly sheared in the y–z plane by an affine
displacement u = f(t) B x imposed on its four faces y, z = const, whose exact answer is known
(below, `shear_gradient`).

With `uniform_weight` set, spheres and FE instead fill the whole block and every sphere is
coupled with the same α = w, β = 1 − w (`UniformOverlap`).

Two ways to weigh the energies in the bridging band (`weighting`):
- "nodal", the paper's (METHOD.md): α_i m_i ü_i = α_i Fg_i + …, β_j M_j d̈_j = β_j F_j − …;
  the weights cancel in the predictors. Not conservative when the weights vary: a ramped band
  makes the coupled system gain energy exponentially (docs/coupling.md, "Coupled 3D block");
- "consistent": each partner integrates its weighted energy, α H_FE (stiffness ∫ α ε:C:ε and
  mass ∫ α ρ N) and β H_DE (sphere masses × β, link forces × the mean β of the two spheres);
  the coupled system is then Hamiltonian and the leap-frog conserves its energy. Set up once,
  no cost per step.
"""
from dataclasses import dataclass

import numpy as np

from orchestrator.bridging import check_weighting




@dataclass
class BlockSpec:
    size: tuple = (0.12, 0.06, 0.06)   # block [0, Lx] × [0, Ly] × [0, Lz] (m)
    de_length: float = 0.048           # x_i: the DE zone is x < x_i
    radius: float = 0.003              # spheres
    element: float = 0.012             # FE element size (cubes)
    layers: int = 2                    # bridging layers
    young: float = 31e9                # FE: the concrete's macroscopic modulus
    poisson: float = 0.22
    density: float = 2400.0            # bulk density of both models
    contact_young: float = 33e9        # CPM contact modulus (platform calibration: E ≈ 31 GPa)
    contact_poisson: float = 0.2       # CPM shear/normal stiffness ratio
    dt_safety: float = 0.5             # × the smaller critical step
    variant: str = "full"
    relaxation: float = 1.0
    rotations: bool = True
    uniform_weight: float = None       # α everywhere: spheres and FE overlap on the whole block
    weighting: str = "nodal"           # "nodal" (the paper's) or "consistent" (see above)

    def __post_init__(self):
        self.size = tuple(float(s) for s in self.size)
        for name in ("de_length", "radius", "element", "young", "density", "contact_young",
                     "contact_poisson", "relaxation"):
            if not getattr(self, name) > 0:
                raise ValueError(f"block: {name} must be > 0, got {getattr(self, name)!r}")
        if not 0 < self.dt_safety <= 1:
            raise ValueError(f"block: dt_safety must be in (0, 1], got {self.dt_safety!r}")
        check_weighting("block", self.weighting)
        if self.uniform_weight is not None and not 0 < self.uniform_weight < 1:
            raise ValueError(f"block: uniform_weight must be in (0, 1), got {self.uniform_weight!r}")
        cells = (np.array(self.size) - self.fe_lo) / self.element
        if np.any(np.abs(cells - np.round(cells)) > 1e-9) or np.any(np.round(cells) < 1):
            raise ValueError(f"block: the FE part {(np.array(self.size) - self.fe_lo).tolist()} m "
                             f"is not a whole number of elements of {self.element:g} m")
        if self.uniform_weight is None and self.de_length + self.width > self.size[0]:
            raise ValueError(f"block: DE zone {self.de_length:g} m + bridging band "
                             f"{self.width:g} m exceed the block length {self.size[0]:g} m")

    @property
    def width(self):
        return self.layers * self.element

    @property
    def fe_lo(self):
        """Lower corner of the FE mesh."""
        return np.array([0.0 if self.uniform_weight is not None else self.de_length, 0.0, 0.0])

    @property
    def de_hi(self):
        """Upper corner of the box the spheres fill."""
        if self.uniform_weight is not None:
            return np.array(self.size)
        return np.array([self.de_length + self.width, self.size[1], self.size[2]])


class UniformOverlap:
    """Weights of a full overlap: α = weight at every FE node, β = 1 − weight at every sphere,
    every sphere coupled (duck-types orchestrator.bridging.Bridging)."""

    def __init__(self, weight):
        self.weight = float(weight)

    def alpha(self, x):
        return np.full(len(np.atleast_2d(x)), self.weight)

    def beta(self, x):
        return np.full(len(np.atleast_2d(x)), 1.0 - self.weight)

    def contains(self, x, tol=0.0):
        return np.ones(len(np.atleast_2d(x)), bool)


class CoupledBlock:
    """The YADE scene, the FE model and the coupling of the block; `stepper` advances both.

    spheres: BodySet of every sphere; bridge: BodySet of the coupled bridging spheres (all
    the bridging spheres except those in `exclude(centres) -> mask`, e.g. spheres whose
    motion is prescribed); beta: β of every sphere; de_weight, fe_weight: the weights per
    sphere and per FE dof that the partners do not carry themselves (β and α for the nodal
    weighting, 1 for the consistent one), which the coupling and the energy apply.
    """

    def __init__(self, spec, exclude=None, fe_partner=None, de_step=None):
        from fenicsx_side.mesh import box_mesh
        from fenicsx_side.model import ElasticModel
        from orchestrator.assembly import bridging_spheres, check_time_step, common_time_step
        from orchestrator.coupling import Coupling
        from orchestrator.bridging import Bridging, HalfSpaceZone
        from orchestrator.timeloop import CoupledStepper
        from yade_side import import_yade
        from yade_side.bulk import BodySet
        from yade_side.packing import add_spheres, dense_box_packing, packing_fraction, sphere_arrays
        from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

        yade = import_yade()
        from yade import utils
        self.O = yade.Omega()
        self.spec = s = spec
        L = np.array(s.size)
        if s.uniform_weight is None:
            zone = HalfSpaceZone((s.de_length, 0, 0), (1, 0, 0))
            self.bridging = Bridging(zone, s.layers, s.element)
        else:
            self.bridging = UniformOverlap(s.uniform_weight)
        centres, radii = sphere_arrays(dense_box_packing((0, 0, 0), s.de_hi, s.radius))
        fraction = packing_fraction(radii, np.prod(s.de_hi))

        reset_scene()
        mat = self.O.materials.append(yade.wrapper.CpmMat(
            young=s.contact_young, poisson=s.contact_poisson, density=s.density / fraction,
            frictionAngle=0.5, sigmaT=1e30, epsCrackOnset=1e30, relDuctility=1.0,
            neverDamage=True))
        self.ids = add_spheres(centres, radii, mat)

        consistent = s.weighting == "consistent"
        n = np.round((L - s.fe_lo) / s.element).astype(int)
        self.fe = ElasticModel(box_mesh(s.fe_lo, L, n), s.young, s.poisson, s.density,
                               weight=self.bridging.alpha if consistent else None)
        de_critical, fe_critical = utils.PWaveTimeStep(), self.fe.critical_dt()
        self.dt = common_time_step(s.dt_safety, de_critical, fe_critical)
        check_time_step(self.dt, de_critical, fe_critical)
        self.law, _ = cpm_engines(dt=self.dt)
        # YADE's default shear kinematics (avoidGranularRatcheting) takes the lever arms as the
        # radii while the law applies the shear force at the contact point, mid-way in the
        # gap of a distant link: not conservative (measured: 1.9 % energy error on this block
        # alone). Contact-point lever arms make the links conservative (6e-8).
        for engine in self.O.engines:
            if isinstance(engine, yade.wrapper.InteractionLoop):
                engine.geomDispatcher.functors[0].avoidGranularRatcheting = False
        create_cohesive_links()
        self.beta = self.bridging.beta(centres)
        if consistent:
            from yade_side.weighting import weight_spheres
            weight_spheres(self.ids, self.beta)
        self.de_weight = np.ones(len(self.ids)) if consistent else self.beta
        self.fe_weight = (np.ones(self.fe.ndof) if consistent
                          else np.repeat(self.bridging.alpha(self.fe.nodes), 3))

        self.spheres = BodySet(self.ids)
        index = bridging_spheres(self.bridging, self.spheres.ref_pos)
        if exclude is not None:
            index = index[~exclude(self.spheres.ref_pos[index])]
        self.bridge_index = index
        self.bridge = BodySet(self.ids[index])
        fe = self.fe if fe_partner is None else fe_partner(self)
        k, h = self.fe.point_operators(self.bridge.ref_pos)
        self.coupling = Coupling(k, h if s.rotations else None, self.bridge.mass,
                                 self.bridge.inertia, self.de_weight[index], fe.mass,
                                 self.fe_weight, fe.fixed, self.dt, variant=s.variant,
                                 relaxation=s.relaxation, rotations=s.rotations)
        self.stepper = CoupledStepper(self.O.step if de_step is None else de_step(self),
                                      self.bridge, fe, self.coupling)

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
    """Energy of the coupled block, H = α H_FE + β H_DE (METHOD.md, eq. 2): FE kinetic and
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
        excess = np.array([_cpm_link_energy(i.phys) for i in self._links])
        return self._w0 * self.b.law.elasticEnergy() + float(self._excess @ excess)


def _cpm_link_energy(phys):
    # what Law2_ScGeom_CpmPhys_Cpm.elasticEnergy() sums per link
    return 0.5 * (phys.normalForce.squaredNorm() / phys.kn + phys.shearForce.squaredNorm() / phys.ks)


# --- the paper's 3D check ------------------------------------------------------------------
def shear_gradient(gamma):
    """B of the simple shear u_y = γ (z − z_c) in the plane of the interface: strain
    ε_yz = γ/2, rotation ω = ½ curl u = (−γ/2, 0, 0). Its stress has σ_xx = σ_xy = σ_xz = 0,
    so the affine field is the exact answer of the whole block whatever the moduli of the two
    models (no traction across the interface or on the faces x = const) once it is imposed
    on the faces y, z = const."""
    B = np.zeros((3, 3))
    B[1, 2] = gamma
    return B


def ramp(t, duration):
    """Smooth loading f(t): ½ (1 − cos π t / T) up to T, then 1."""
    return np.where(t < duration, 0.5 * (1 - np.cos(np.pi * np.minimum(t, duration) / duration)), 1.0)


def axial(B):
    """ω of the displacement gradient B: the axial vector of ½ (B − Bᵀ)."""
    return 0.5 * np.array([B[2, 1] - B[1, 2], B[0, 2] - B[2, 0], B[1, 0] - B[0, 1]])


def rotation_vector(ori):
    """Small rotation vectors of unit quaternions (x, y, z, w) that start at the identity."""
    return 2.0 * ori[:, :3] * np.sign(ori[:, 3:])


class PrescribedFE:
    """The FE partner with the displacement of `dofs` prescribed: after each predictor the
    prescribed dofs are corrected to motion(t + Δt) (an exact central difference, like the
    coupling's corrections); the coupling sees them as fixed."""

    def __init__(self, fe, dofs, motion):
        self.fe, self.dofs, self.motion = fe, dofs, motion
        self.fixed = np.zeros(fe.ndof, bool)
        self.fixed[dofs] = True

    def __getattr__(self, name):
        return getattr(self.fe, name)

    def predict(self, dt):
        self.fe.predict(dt)
        self.fe.correct(self.dofs, self.motion(self.fe.t)[self.dofs] - self.fe.u[self.dofs], dt)


@dataclass
class ShearCheck:
    gamma: float = 1e-4
    ramp_steps: int = 600     # ≈ 10 periods of the block's lowest shear mode
    hold_steps: int = 400     # the displacements and rotations are averaged over these
    wall: float = 2.0         # spheres with centres within wall × R of a face y, z = const are prescribed

    def __post_init__(self):
        if not self.gamma > 0:
            raise ValueError(f"shear check: gamma must be > 0, got {self.gamma!r}")
        for name in ("ramp_steps", "hold_steps"):
            if int(getattr(self, name)) != getattr(self, name) or getattr(self, name) < 1:
                raise ValueError(f"shear check: {name} must be a positive integer, "
                                 f"got {getattr(self, name)!r}")


def run_shear_check(spec, check):
    """Shear the block slowly (ShearCheck) and measure, averaged over the hold, the relative
    RMS error of the sphere displacements and rotations against the exact affine field, for
    the coupled bridging spheres and for the free spheres of the DE zone."""
    from yade_side.bulk import BodySet

    L = np.array(spec.size)
    centre = 0.5 * L
    B = shear_gradient(check.gamma)
    w_exact = axial(B)
    lateral = lambda x: np.any((np.abs(x[:, 1:] - 0) < check.wall * spec.radius)
                               | (np.abs(x[:, 1:] - L[1:]) < check.wall * spec.radius), axis=1)
    state = {}

    def fe_partner(block):
        nodes = block.fe.nodes
        on_face = np.any(np.isclose(nodes[:, 1:], 0) | np.isclose(nodes[:, 1:], L[1:]), axis=1)
        dofs = np.flatnonzero(np.repeat(on_face, 3))
        shape = ((nodes - centre) @ B.T).ravel()
        return PrescribedFE(block.fe, dofs, lambda t: ramp(t, state["T"]) * shape)

    def de_step(block):
        walls = BodySet(block.ids[lateral(block.spheres.ref_pos)])
        shape = (walls.ref_pos - centre) @ B.T

        def step():
            block.O.step()
            walls.predict(block.dt)
            state["t"] += block.dt
            f = ramp(state["t"], state["T"])
            walls.correct(block.ref_wall + f * shape - walls.pos,
                          f * w_exact - walls.rotation_pred, block.dt)

        block.ref_wall = walls.ref_pos
        return step

    # the ramp duration needs Δt, known once the block is built: `state` is read lazily;
    # the FE's own clock fe.t and the spheres' state["t"] both start at 0 with the run
    block = CoupledBlock(spec, exclude=lateral, fe_partner=fe_partner, de_step=de_step)
    state.update(T=check.ramp_steps * block.dt, t=0.0)

    s = block.spheres
    free = ~lateral(s.ref_pos)
    sets = {"bridging": np.zeros(len(s), bool), "de_zone": free & (block.beta >= 1.0)}
    sets["bridging"][block.bridge_index] = True
    d_exact = (s.ref_pos - centre) @ B.T
    mean_d, mean_w = np.zeros_like(d_exact), np.zeros_like(d_exact)
    for n in range(check.ramp_steps + check.hold_steps):
        block.stepper.step()
        if n >= check.ramp_steps:
            s.read()
            mean_d += s.displacement()
            mean_w += rotation_vector(s.ori)
    mean_d /= check.hold_steps
    mean_w /= check.hold_steps
    errors = {}
    for name, mask in sets.items():
        errors[name] = {
            "spheres": int(mask.sum()),
            "displacement": _relative_rms(mean_d[mask], d_exact[mask]),
            "rotation": _relative_rms(mean_w[mask], np.broadcast_to(w_exact, (mask.sum(), 3))),
        }
    return {"errors": errors, "dt": block.dt, "positions": s.ref_pos, "rotation": mean_w,
            "displacement": mean_d, "sets": sets, "rotation_exact": w_exact,
            "coupling_seconds": block.stepper.seconds}


def _relative_rms(value, exact):
    return float(np.linalg.norm(value - exact) / np.linalg.norm(exact))
