"""The coupling on the real FE partner (dolfinx) with force-free spheres as the DE side:
kinematics that the method must reproduce exactly."""
import numpy as np
import pytest

from fenicsx_side.mesh import box_mesh_with_hole
from fenicsx_side.model import ElasticModel
from orchestrator.coupling.assembly import bridging_spheres, make_coupling
from orchestrator.coupling.bridging import BoxZone, Bridging
from orchestrator.coupling.correction import Coupling
from orchestrator.stepper import CoupledStepper

H = 0.1  # element size


class FreeSpheres:
    """Spheres with no forces on them: the DE predictor is a free flight."""

    def __init__(self, centres, radius, rho):
        self.ref_pos = centres
        self.mass = np.full(len(centres), rho * 4 / 3 * np.pi * radius**3)
        self.inertia = 0.4 * self.mass * radius**2
        self.d = np.zeros_like(centres)
        self.w = np.zeros_like(centres)
        self.v = np.zeros_like(centres)
        self.angvel = np.zeros_like(centres)
        self.rotation_pred = self.w

    def step(self, dt):
        self.d += dt * self.v
        self.w += dt * self.angvel

    def predict(self, dt):
        pass

    def displacement(self):
        return self.d

    def correct(self, dd, dw, dt):
        self.d += dd
        self.v += dd / dt
        self.w += dw
        self.angvel += dw / dt


@pytest.fixture(scope="module")
def frame():
    """A 1 × 1 × 0.2 plate, DE zone [0.4, 0.6]² through the thickness, 2 bridging layers."""
    msh = box_mesh_with_hole([0, 0, 0], [1, 1, 0.2], [10, 10, 2], [0.4, 0.4, 0], [0.6, 0.6, 0.2])
    fe = ElasticModel(msh, 30e9, 0.2, 2400.0)
    bridging = Bridging(BoxZone([0.4, 0.4, 0], [0.6, 0.6, 0.2]), layers=2, element_size=H)
    rng = np.random.default_rng(1)
    centres = rng.uniform([0.2, 0.2, 0.01], [0.8, 0.8, 0.19], size=(600, 3))
    centres = centres[bridging_spheres(bridging, centres)]
    return fe, bridging, centres


def coupled(frame, variant="full", relaxation=1.0):
    fe, bridging, centres = frame
    fe.u, fe.v = np.zeros(fe.ndof), np.zeros(fe.ndof)
    spheres = FreeSpheres(centres.copy(), 0.01, 2400 / 0.6)
    dt = 0.5 * fe.critical_dt()
    cpl = make_coupling(fe, bridging, spheres, dt, variant, relaxation)
    return CoupledStepper(lambda: spheres.step(dt), spheres, fe, cpl), fe, spheres


def rigid_velocity(x, a, w):
    return a + np.cross(w, x)


@pytest.mark.parametrize("variant", ["full", "diagonal"])
def test_rigid_motion_needs_no_multipliers_and_stays_rigid(frame, variant):
    """A rigid velocity field (translation + infinitesimal rotation) on both models: K u = 0,
    the spheres fly freely, the constraints stay satisfied, so λ = 0 to round-off."""
    stepper, fe, spheres = coupled(frame, variant)
    a, w = np.array([1.0, -2.0, 0.5]), np.array([0.3, -0.1, 0.2])
    fe.v = rigid_velocity(fe.nodes, a, w).ravel()
    spheres.v[:] = rigid_velocity(spheres.ref_pos, a, w)
    spheres.angvel[:] = w
    steps = 20
    for _ in range(steps):
        c = stepper.step()
        scale = np.abs(c.q).max()
        assert np.abs(c.gap_pred).max() < 1e-12 * scale
        assert np.abs(c.dd).max() < 1e-12 * scale and np.abs(c.du).max() < 1e-12 * scale
    t = steps * stepper.dt
    assert np.allclose(fe.u.reshape(-1, 3), t * rigid_velocity(fe.nodes, a, w), rtol=1e-10, atol=0)
    assert np.allclose(spheres.w, t * w, rtol=1e-12)


@pytest.mark.parametrize("variant", ["full", "diagonal"])
def test_linear_field_is_reproduced_by_sphere_displacements_and_rotations(frame, variant):
    """Spheres at rest, an imposed FE field u = B x (every FE dof held: W⁻¹ = 0). Then S is
    diagonal, both variants are exact, and one correction gives d_j = B x_j and
    ω_j = axial(½(B − Bᵀ)) at every bridging sphere, whatever its element."""
    fe, bridging, centres = frame
    spheres = FreeSpheres(centres.copy(), 0.01, 2400 / 0.6)
    B = 1e-4 * np.array([[1.0, 2.0, -1.0], [0.5, -1.0, 3.0], [-2.0, 1.0, 0.5]])
    u = (fe.nodes @ B.T).ravel()
    k, h = fe.point_operators(spheres.ref_pos)
    cpl = Coupling(k, h, spheres.mass, spheres.inertia, bridging.beta(spheres.ref_pos), fe.mass,
                   np.ones(fe.ndof), np.ones(fe.ndof, bool), 1e-6, variant=variant)
    c = cpl.correct(spheres.d, spheres.w, u)
    d_exact = spheres.ref_pos @ B.T
    w_exact = 0.5 * np.array([B[2, 1] - B[1, 2], B[0, 2] - B[2, 0], B[1, 0] - B[0, 1]])
    assert np.allclose(c.dd, d_exact, rtol=0, atol=1e-12 * np.abs(d_exact).max())
    assert np.allclose(c.dw, np.broadcast_to(w_exact, c.dw.shape), rtol=0,
                       atol=1e-12 * np.abs(B).max())
    assert not c.du.any()
