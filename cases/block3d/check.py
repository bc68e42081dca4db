"""The paper's 3D check: the coupled block sheared slowly into a known affine field."""
from dataclasses import dataclass

import numpy as np

from cases.block3d.model import CoupledBlock


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
    coupled: bool = True      # False: the spheres alone (a DE block with its walls prescribed
                              # and free faces x = const; the FE is not stepped): the packing's
                              # own error, with no coupling at all

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

    def fe_partner(fe):
        nodes = fe.nodes
        on_face = np.any(np.isclose(nodes[:, 1:], 0) | np.isclose(nodes[:, 1:], L[1:]), axis=1)
        dofs = np.flatnonzero(np.repeat(on_face, 3))
        shape = ((nodes - centre) @ B.T).ravel()
        return PrescribedFE(fe, dofs, lambda t: ramp(t, state["T"]) * shape)

    # the ramp duration needs Δt, known once the block is built: `state` is read lazily;
    # the FE's own clock fe.t and the spheres' state["t"] both start at 0 with the run
    block = CoupledBlock(spec, exclude=lateral, fe_partner=fe_partner)
    state.update(T=check.ramp_steps * block.dt, t=0.0)
    walls = BodySet(block.ids[lateral(block.spheres.ref_pos)])
    wall_shape, wall_ref = (walls.ref_pos - centre) @ B.T, walls.ref_pos

    def de_step():
        block.O.step()
        walls.predict(block.dt)
        state["t"] += block.dt
        f = ramp(state["t"], state["T"])
        walls.correct(wall_ref + f * wall_shape - walls.pos, f * w_exact - walls.rotation_pred,
                      block.dt)

    block.stepper.de_step = de_step

    s = block.spheres
    free = ~lateral(s.ref_pos)
    sets = {"bridging": np.zeros(len(s), bool), "de_zone": free & (block.beta >= 1.0)}
    sets["bridging"][block.bridge_index] = True
    # bridging spheres with a guarded rotation row (diagonal solver), and the others
    guarded = np.zeros(len(s), bool)
    guarded[block.bridge_index[block.coupling.guarded_rotation_spheres]] = True
    if guarded.any():
        sets["bridging_guarded"] = guarded
        sets["bridging_unguarded"] = sets["bridging"] & ~guarded
    d_exact = (s.ref_pos - centre) @ B.T
    mean_d, mean_w = _held_means(block, check)
    errors = {name: {"spheres": int(mask.sum()),
                     "displacement": relative_rms(mean_d[mask], d_exact[mask]),
                     "rotation": relative_rms(mean_w[mask],
                                               np.broadcast_to(w_exact, (mask.sum(), 3)))}
              for name, mask in sets.items()}
    return {"errors": errors, "dt": block.dt, "positions": s.ref_pos, "rotation": mean_w,
            "displacement": mean_d, "displacement_exact": d_exact, "sets": sets,
            "rotation_exact": w_exact, "coupling_seconds": block.stepper.seconds,
            "guarded_rotation_rows": block.coupling.guarded_rotation_rows,
            "rotation_rows": 3 * block.coupling.n if spec.rotations else 0}


def _held_means(block, check):
    """Ramp, then hold: the spheres' displacements and rotation vectors averaged over the
    hold."""
    s = block.spheres
    mean_d, mean_w = np.zeros((len(s), 3)), np.zeros((len(s), 3))
    step = block.stepper.step if check.coupled else block.stepper.de_step
    for n in range(check.ramp_steps + check.hold_steps):
        step()
        if n >= check.ramp_steps:
            s.read()
            mean_d += s.displacement()
            mean_w += rotation_vector(s.ori)
    return mean_d / check.hold_steps, mean_w / check.hold_steps


def relative_rms(value, exact):
    return float(np.linalg.norm(value - exact) / np.linalg.norm(exact))
