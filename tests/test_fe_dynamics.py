"""Explicit dynamics of ElasticModel against exact answers.

A hexahedral bar one element thick, with ν = 0 and its lateral components fixed, is exactly the
1D lumped linear-element chain: each cross-section moves as one, with mass ρ A h and springs
E A / h. Its central-difference dispersion is sin(ω Δt/2) = C sin(k h/2), C = c Δt/h, c = √(E/ρ).
"""
import numpy as np
import pytest

from fenicsx_side.mesh import box_mesh
from fenicsx_side.model import ElasticModel, face

E, RHO = 30e9, 2400.0
C_BAR = np.sqrt(E / RHO)
ALL = lambda x: np.full(x.shape[1], True)  # every boundary facet (all of a one-element bar)


def bar(length, h):
    msh = box_mesh((0, 0, 0), (length, h, h), (round(length / h), 1, 1))
    return ElasticModel(msh, E, 0.0, RHO, dirichlet=[(ALL, (1, 2))])


def test_critical_dt_of_the_lumped_bar_is_h_over_c():
    """ω_max = 2c/h: the alternating mode (free ends) is an element eigenvector with the
    largest element eigenvalue 4c²/h² (the other x-only element modes have at most 2c²/h²)."""
    h = 0.02
    m = bar(1.0, h)
    assert m.critical_dt() == pytest.approx(h / C_BAR, rel=1e-8)


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_critical_dt_matches_a_dense_eigensolve(cell):
    """3D, ν = 0.3, a clamped face and a roller face: Lanczos against the full spectrum of
    M^-½ K M^-½ restricted to the free dofs."""
    msh = box_mesh((0, 0, 0), (0.6, 0.4, 0.3), (3, 2, 2), cell)
    m = ElasticModel(msh, E, 0.3, RHO, dirichlet=[(face(0, 0.0), (0, 1, 2)), (face(2, 0.3), (2,))])
    free = ~m.fixed
    scale = 1 / np.sqrt(m.mass[free])
    S = m.K.toarray()[np.ix_(free, free)] * np.outer(scale, scale)
    omega_max = np.sqrt(np.linalg.eigvalsh(S)[-1])
    assert m.critical_dt() == pytest.approx(2 / omega_max, rel=1e-8)


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_critical_dt_bound_is_gershgorins_and_below_the_critical_step(cell):
    """The bound is 2/√ of the largest absolute row sum of M^-½ K M^-½ over the free dofs
    (dense here), which by Gershgorin's theorem is at least its largest eigenvalue: at most
    the critical step, on the 3D box and on the bar."""
    msh = box_mesh((0, 0, 0), (0.6, 0.4, 0.3), (3, 2, 2), cell)
    m = ElasticModel(msh, E, 0.3, RHO, dirichlet=[(face(0, 0.0), (0, 1, 2)), (face(2, 0.3), (2,))])
    free = ~m.fixed
    scale = 1 / np.sqrt(m.mass[free])
    S = m.K.toarray()[np.ix_(free, free)] * np.outer(scale, scale)
    assert m.critical_dt_bound() == pytest.approx(2 / np.sqrt(np.abs(S).sum(axis=1).max()),
                                                  rel=1e-12)
    assert m.critical_dt_bound() <= m.critical_dt() * (1 + 1e-12)
    b = bar(1.0, 0.02)
    assert b.critical_dt_bound() <= b.critical_dt() * (1 + 1e-12)


def test_critical_dt_started_from_another_models_mode_is_the_same():
    """A grown zone's FE part is the old one less cells: its critical step, started from the
    old part's dominant mode on its nodes (or from a mode that is not its own), is the one
    found from SLEPc's own start, to the eigenvalue's tolerance."""
    from fenicsx_side.cells import box_mesh_without_cells
    dirichlet = [(face(0, 0.0), (0, 1, 2))]
    whole = ElasticModel(box_mesh((0, 0, 0), (0.6, 0.4, 0.3), (6, 4, 3)), E, 0.3, RHO,
                         dirichlet=dirichlet)
    removed = np.zeros((6, 4, 3), bool)
    removed[2:4, 1:3, :] = True
    part = ElasticModel(box_mesh_without_cells((0, 0, 0), (0.6, 0.4, 0.3), (6, 4, 3), removed),
                        E, 0.3, RHO, dirichlet=dirichlet)
    whole.critical_dt()
    at = [int(np.argmin(np.linalg.norm(whole.nodes - x, axis=1))) for x in part.nodes]
    cold = part.critical_dt()
    assert part.critical_dt(whole.dominant_mode.reshape(-1, 3)[at].ravel()) == \
        pytest.approx(cold, rel=1e-10)
    rng = np.random.default_rng(0)
    assert part.critical_dt(rng.standard_normal(3 * len(part.nodes))) == \
        pytest.approx(cold, rel=1e-10)


def exact_chain(u0, h, dt, times):
    """Right-going solution of the discrete chain with initial nodal displacement u0 (far
    from the ends): u(t) = Σ_k û(k) e^{i(kx − ω(k) t)}, sin(ω dt/2) = C sin(kh/2)."""
    k = 2 * np.pi * np.fft.fftfreq(len(u0), h)
    omega = 2 / dt * np.arcsin(C_BAR * dt / h * np.sin(k * h / 2))
    spectrum = np.fft.fft(u0)
    return [np.fft.ifft(spectrum * np.exp(-1j * omega * t)).real for t in times]


def test_pulse_travels_as_the_discrete_chain_predicts():
    """A Gaussian pulse (σ = 4 h) launched right-going: the FE bar reproduces the exact discrete
    chain solution node by node, and the pulse centre moves at the energy-averaged discrete group
    velocity, slower than c by (1 − C²) h²/(16 σ²) to leading order."""
    h, courant, sigma, x0, travel = 0.01, 0.5, 0.04, 0.5, 2.0
    m = bar(3.0, h)
    dt = courant * h / C_BAR
    steps = round(travel / (C_BAR * dt))
    x = h * np.arange(round(3.0 / h) + 1)
    line = np.rint(m.nodes[:, 0] / h).astype(int)     # chain index of each FE node
    pulse = 1e-5 * np.exp(-0.5 * ((x - x0) / sigma) ** 2)
    u_start, u_back = exact_chain(pulse, h, dt, [0.0, -dt])
    m.u = np.column_stack([u_start[line], np.zeros((len(line), 2))]).ravel()
    m.v = np.column_stack([(u_start - u_back)[line] / dt, np.zeros((len(line), 2))]).ravel()
    for _ in range(steps):
        m.predict(dt)
    (u_end,) = exact_chain(pulse, h, dt, [steps * dt])
    ux = m.u[0::3]
    assert np.abs(ux - u_end[line]).max() <= 1e-10 * pulse.max()

    def centre(values):
        return np.sum(x * values ** 2) / np.sum(values ** 2)

    speed = (centre(u_end) - centre(pulse)) / (steps * dt)
    k = np.linspace(0, np.pi / h, 20001)
    weight = np.exp(-(k * sigma) ** 2)                 # |û(k)|² of the Gaussian
    group = C_BAR * np.cos(k * h / 2) / np.sqrt(1 - (courant * np.sin(k * h / 2)) ** 2)
    assert speed == pytest.approx(np.trapz(group * weight, k) / np.trapz(weight, k), rel=1e-6)
    deficit = 1 - speed / C_BAR
    # next order: relative O(h²/σ²) ≈ 6 %
    assert deficit == pytest.approx((1 - courant ** 2) * h ** 2 / (16 * sigma ** 2), rel=0.06)
    # the FE nodes, not only the chain formula, carry the pulse at that speed
    fe_speed = (centre(np.bincount(line, ux) / 4) - centre(pulse)) / (steps * dt)
    assert fe_speed == pytest.approx(speed, rel=1e-8)


def test_free_vibration_conserves_the_leapfrog_invariant():
    """H = ½ v₋·M v₊ + ½ u·K u is exactly conserved by central differences; the energy with
    the mid-point velocity v̄ = (v₋ + v₊)/2 exceeds it by Δt²/8 (Ku)·M⁻¹(Ku) ≤ (Δt/Δt_c)² U."""
    msh = box_mesh((0, 0, 0), (1.0, 0.5, 0.3), (8, 4, 3))
    m = ElasticModel(msh, E, 0.25, RHO, dirichlet=[(face(0, 0.0), (0, 1, 2))])
    x = m.nodes
    shape = np.column_stack([x[:, 0] ** 2, 0.5 * x[:, 0] * x[:, 1], np.sin(3 * x[:, 0]) * x[:, 2]])
    m.u = np.where(m.fixed, 0.0, 1e-4 * shape.ravel())
    dt_c = m.critical_dt()
    dt = 0.8 * dt_c
    invariant, excess, bound = [], [], []
    for _ in range(400):
        u, v_before = m.u.copy(), m.v.copy()
        ku = m.K @ u
        m.predict(dt)
        invariant.append(0.5 * np.sum(m.mass * v_before * m.v) + 0.5 * u @ ku)
        v_mid = 0.5 * (v_before + m.v)
        excess.append(0.5 * np.sum(m.mass * v_mid ** 2) + 0.5 * u @ ku - invariant[-1])
        bound.append((dt / dt_c) ** 2 * 0.5 * u @ ku)
    invariant = np.array(invariant)
    # 400 steps of round-off, each ~1e-16 relative
    assert np.abs(invariant / invariant[0] - 1).max() < 1e-12
    assert np.all(np.array(excess) >= -1e-13 * invariant[0])
    assert np.all(np.array(excess) <= np.array(bound) + 1e-13 * invariant[0])
    assert max(excess) > 1e-6 * invariant[0]  # the plain energy does oscillate
    # model helpers: kinetic energy of the half-step velocity, strain energy of u
    assert m.kinetic_energy() == pytest.approx(0.5 * np.sum(m.mass * m.v ** 2), rel=1e-14)
    w = np.linspace(0, 1, m.ndof)
    assert m.strain_energy(w) == pytest.approx(0.5 * np.sum(w * m.u * (m.K @ m.u)), rel=1e-14)
