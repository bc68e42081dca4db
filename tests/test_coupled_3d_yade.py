"""The coupling on both real partners: YADE spheres with elastic CPM links (never damaged)
and the dolfinx FE model, as a 3D block (cases/block3d.py)."""
import numpy as np
import pytest

from cases.block3d import BlockSpec, CoupledBlock, WeightedEnergy

# half-space bridging (the paper's arrangement): DE zone x < 0.048, 2 bridging layers of 12 mm
HALF_SPACE = dict(size=(0.084, 0.048, 0.048), de_length=0.048)
# full overlap with uniform weights α = β = ½: the paper's nodal weighting is then conservative
OVERLAP = dict(size=(0.072, 0.048, 0.048), uniform_weight=0.5, weighting="nodal")
# the arrangements in which the coupled system has an exact energy
CONSERVATIVE = {"uniform overlap, nodal weights": OVERLAP,
                "half-space, consistent weights": dict(HALF_SPACE, weighting="consistent")}
EPS = np.finfo(float).eps
V0 = 0.01  # m/s, velocity amplitude of the free vibrations


def vibration(block):
    """Free vibration from a smooth velocity field with zero momentum and zero angular
    momentum (cos πx/L and cos 2πx/L are orthogonal to 1 and x on [0, L]), which shears the
    block, so sphere rotations take part."""
    L = block.spec.size[0]
    k1, k2 = np.pi / L, 2 * np.pi / L
    velocity = lambda x: V0 * np.column_stack([np.cos(k1 * x[:, 0]), np.cos(k2 * x[:, 0]),
                                               np.zeros(len(x))])
    rate = lambda x: np.column_stack([np.zeros((len(x), 2)), -0.5 * V0 * k2 * np.sin(k2 * x[:, 0])])
    block.set_velocity_field(velocity, rate)


def energy_history(block, steps):
    """H(t) of every step, and the largest relative constraint residual |q − G u| / |q| seen."""
    vibration(block)
    meter = WeightedEnergy(block)
    energy, residual = [], 0.0
    for _ in range(steps):
        meter.before()
        c = block.stepper.step()
        energy.append(meter.after())
        residual = max(residual, np.abs(c.q - c.Gu).max() / np.abs(c.q).max())
    return np.array(energy), residual


def nonlinearity_bound(spec):
    """The exact leap-frog invariant of a linear system is what WeightedEnergy measures; YADE's
    links are geometrically nonlinear, with relative corrections of the order of the largest
    strain, which a wave of velocity amplitude V0 keeps below V0 / c_shear."""
    c_shear = np.sqrt(spec.young / (2 * (1 + spec.poisson)) / spec.density)
    return V0 / c_shear


STEPS = 400  # ≈ 6 periods of the block's first longitudinal mode (2 L / c ≈ 40 µs, Δt ≈ 0.6 µs)


@pytest.mark.parametrize("contact_point_arms", [True, False])
def test_spheres_alone_conserve_energy_only_with_contact_point_lever_arms(contact_point_arms):
    """The block's spheres alone (no coupling, FE at rest). YADE's default shear kinematics
    (avoidGranularRatcheting) uses the radii as lever arms while CPM applies the shear force at
    the contact point, mid-gap of a distant link: not conservative (measured 1.9 %, the same at
    any amplitude); CoupledBlock's contact-point arms are (measured 6e-8). Uniform weights:
    the spheres' weighted energy is ½ their own."""
    block = CoupledBlock(BlockSpec(**OVERLAP))
    for engine in block.O.engines:
        if type(engine).__name__ == "InteractionLoop":
            engine.geomDispatcher.functors[0].avoidGranularRatcheting = not contact_point_arms
    vibration(block)
    block.fe.v = np.zeros(block.fe.ndof)
    meter = WeightedEnergy(block)
    e = []
    for _ in range(STEPS):
        meter.before()
        block.O.step()
        e.append(meter.after())
    error = np.abs(np.array(e) / e[0] - 1).max()
    if contact_point_arms:
        assert error < nonlinearity_bound(block.spec)
    else:
        assert error > 100 * nonlinearity_bound(block.spec)


@pytest.mark.parametrize("arrangement", CONSERVATIVE)
def test_full_lagrange_conserves_the_energy(arrangement):
    """The coupled system is Hamiltonian (uniform weights, or weights inside the partners'
    masses and stiffnesses): central differences with exactly enforced linear constraints
    conserve its leap-frog invariant, so the only error left is the links' geometric
    nonlinearity (measured: 4e-8 and 8e-8); the constraints hold to round-off every step."""
    block = CoupledBlock(BlockSpec(**CONSERVATIVE[arrangement]))
    assert STEPS * block.dt > 5 * 2 * block.spec.size[0] / np.sqrt(block.spec.young / block.spec.density)
    e, residual = energy_history(block, STEPS)
    assert np.abs(e / e[0] - 1).max() < nonlinearity_bound(block.spec)
    assert residual < 1e-12


@pytest.mark.parametrize("variant,relaxation", [("diagonal", 1.0), ("full", 35.0), ("diagonal", 35.0)])
def test_diagonal_and_relaxed_variants_create_no_energy(variant, relaxation):
    """Half-space bridging, consistent weights: what these variants leave of the constraint
    can only dissipate (measured over 1,500 steps: 6 % with r = 1, 82 % with r = 35)."""
    block = CoupledBlock(BlockSpec(variant=variant, relaxation=relaxation,
                                   **CONSERVATIVE["half-space, consistent weights"]))
    e, _ = energy_history(block, STEPS)
    assert np.all(np.isfinite(e))
    assert e.max() <= e[0] * (1 + nonlinearity_bound(block.spec)), \
        f"energy grew by {e.max() / e[0] - 1:.3e}"


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the paper's nodal weighting (α_i Fg_i, β_j F_j) is not "
                   "conservative across a ramped bridging band: measured exponential energy "
                   "growth (docs/coupling.md, 'Coupled 3D block')")
@pytest.mark.parametrize("variant,relaxation", [("full", 1.0), ("diagonal", 35.0)])
def test_half_space_bridging_creates_no_energy(variant, relaxation):
    block = CoupledBlock(BlockSpec(variant=variant, relaxation=relaxation, weighting="nodal",
                                   **HALF_SPACE))
    e, _ = energy_history(block, 3000)
    # the weighted energy of a ramped band is not an invariant; its window means must not grow
    windows = e.reshape(6, -1).mean(axis=1) / e[0]
    assert windows.max() <= 2.0, f"window means of H / H(0): {np.round(windows, 2).tolist()}"


@pytest.mark.parametrize("rotation", [False, True])
def test_rigid_motion_of_spheres_and_fe_needs_no_multipliers(rotation):
    """A rigid velocity a + w × x (and angular velocity w) on every sphere and FE node.
    Translation: no link stretches, the predicted gaps are round-off. Rotation: the spheres
    fly straight, which stretches a link of length l ≤ 3R by ε = ½ (|w| t)²; the force that
    makes in one step moves a sphere by at most (ω_max Δt)² ε l < 4 ε · 3R, which bounds the
    predicted gap; its torque, at a lever arm ≤ 1.5 R on an inertia 0.4 M R², turns the sphere
    by at most 3.75 / R times that; the FE sees K u = 0 exactly."""
    block = CoupledBlock(BlockSpec(**HALF_SPACE))
    a = np.array([0.3, -0.2, 0.1])
    w = np.array([2.0, -3.0, 4.0]) if rotation else np.zeros(3)
    centre = 0.5 * np.array(block.spec.size)
    field = lambda x: a + np.cross(w, x - centre)
    block.set_velocity_field(field, lambda x: np.broadcast_to(w, x.shape).copy())
    steps = 30
    t = steps * block.dt
    x_max = np.abs(block.spheres.ref_pos).max()
    bound = 12 * block.spec.radius * 0.5 * (np.linalg.norm(w) * t) ** 2 + 64 * EPS * x_max
    for _ in range(steps):
        c = block.stepper.step()
        n3 = 3 * len(block.bridge)
        assert np.abs(c.gap_pred[:n3]).max() <= bound
        assert np.abs(c.gap_pred[n3:]).max() <= 3.75 * bound / block.spec.radius
        assert np.abs(c.dd).max() <= bound and np.abs(c.du).max() <= bound
    # both models moved rigidly: FE exactly, spheres up to the accumulated link forces
    expected_fe = t * field(block.fe.nodes)
    assert np.allclose(block.fe.u.reshape(-1, 3), expected_fe, rtol=0,
                       atol=steps * bound + 1e-12 * np.abs(expected_fe).max())
    block.spheres.read()
    assert np.allclose(block.spheres.displacement(), t * field(block.spheres.ref_pos), rtol=0,
                       atol=steps**2 * bound + 64 * EPS * x_max)
    # rotations move only through corrections, each at most a gap over a lever arm R
    assert np.allclose(block.bridge.rotation, t * w, rtol=0,
                       atol=steps * bound / block.spec.radius + 64 * EPS * np.linalg.norm(w) * t)


@pytest.mark.slow
def test_block3d_command_writes_the_table_and_plot(tmp_path):
    from cli.main import main
    out = tmp_path / "check"
    assert main(["block3d", "--ramp-steps", "20", "--hold-steps", "5", "--out", str(out)]) == 0
    assert (out / "table.md").read_text().count("| full, r = 1 |") == 2
    assert (out / "block3d.png").stat().st_size > 0
    assert main(["block3d", "--out", str(out)]) == 2  # never overwritten without --force
    assert main(["block3d", "--gamma", "-1", "--out", str(tmp_path / "bad")]) == 2


def test_weighted_fe_model_is_the_model_of_the_weighted_energy():
    """ElasticModel(weight=α): K = ∫ α ε:C:ε and m = ∫ α ρ N. A uniform weight c scales
    both by c; a linear α gives the total mass ρ ∫ α dV = ρ V α(centre); rigid motions still
    cost no energy."""
    from fenicsx_side.mesh import box_mesh
    from fenicsx_side.model import ElasticModel
    msh = box_mesh((0, 0, 0), (1.0, 0.5, 0.5), (4, 2, 2))
    plain = ElasticModel(msh, 30e9, 0.2, 2400.0)
    uniform = ElasticModel(msh, 30e9, 0.2, 2400.0, weight=lambda x: np.full(len(x), 0.3))
    assert np.allclose(uniform.mass, 0.3 * plain.mass, rtol=1e-14)
    assert abs(uniform.K - 0.3 * plain.K).max() <= 1e-13 * abs(plain.K).max()
    ramp = ElasticModel(msh, 30e9, 0.2, 2400.0, weight=lambda x: 0.2 + 0.6 * x[:, 0])
    assert ramp.mass.sum() / 3 == pytest.approx(2400.0 * 0.25 * (0.2 + 0.6 * 0.5), rel=1e-13)
    rigid = (np.array([1.0, -2.0, 0.5]) + np.cross([0.3, -0.1, 0.2], ramp.nodes)).ravel()
    assert np.abs(ramp.K @ rigid).max() <= 1e-12 * abs(ramp.K).max() * np.abs(rigid).max()
    with pytest.raises(ValueError, match="weight"):
        ElasticModel(msh, 30e9, 0.2, 2400.0, weight=lambda x: x[:, 0] - 0.5)


def test_cubic_lattice_fills_the_box_at_spacing_2r():
    from cases.block3d import cubic_lattice
    centres, radii = cubic_lattice((0.072, 0.06, 0.06), 0.003)
    assert len(centres) == 12 * 10 * 10 and np.all(radii == 0.003)
    assert centres.min(axis=0) == pytest.approx([0.003] * 3)
    assert centres.max(axis=0) == pytest.approx([0.069, 0.057, 0.057])


@pytest.mark.slow
def test_shear_check_is_exact_on_a_cubic_lattice():
    """On a simple cubic lattice (face and edge links: cubic symmetry) the affine shear with
    ω = ½ curl u is an exact equilibrium, so the coupled block must reproduce it: what is
    left is the ramp's lag, below (T₁ / 2T)² = (1/20)² for a ramp T of 10 periods T₁ of the
    lowest shear mode (docs/coupling.md: 1e-5 measured)."""
    from cases.block3d import BlockSpec, ShearCheck, run_shear_check
    result = run_shear_check(BlockSpec(packing="cubic", weighting="consistent"), ShearCheck())
    for where in ("bridging", "de_zone"):
        for what in ("displacement", "rotation"):
            assert result["errors"][where][what] < (1 / 20) ** 2, (where, what)
