"""The multiplier algebra on synthetic operators: exact answers, no solver needed."""
import numpy as np
import pytest
import scipy.sparse as sp

from orchestrator.coupling.bridging import BoxZone, Bridging, HalfSpaceZone
from orchestrator.coupling.correction import Coupling
from orchestrator.coupling.multipliers import FullSolver, multiplier_matrix

EPS = np.finfo(float).eps


def synthetic(n=40, nodes=60, seed=0):
    """Operators shaped like k and h: each sphere sees 8 nodes, k rows are partitions of
    unity (N_i ≥ 0), h rows have entries of both signs."""
    rng = np.random.default_rng(seed)
    rows_k, rows_h, cols, vk, vh = [], [], [], [], []
    for j in range(n):
        nn = rng.choice(nodes, 8, replace=False)
        N = rng.random(8)
        N /= N.sum()
        grad = rng.normal(size=(8, 3))
        grad -= grad.mean(axis=0)  # Σ ∇N_i = 0, as for shape functions
        for a in range(8):
            g = grad[a]
            cross = 0.5 * np.array([[0, -g[2], g[1]], [g[2], 0, -g[0]], [-g[1], g[0], 0]])
            for c in range(3):
                for e in range(3):
                    rows_h.append(3 * j + c); cols.append(3 * nn[a] + e); vh.append(cross[c, e])
                    rows_k.append(3 * j + c); vk.append(N[a] if c == e else 0.0)
    shape = (3 * n, 3 * nodes)
    k = sp.csr_matrix((vk, (rows_k, cols)), shape=shape)
    h = sp.csr_matrix((vh, (rows_h, cols)), shape=shape)
    return dict(
        k=k, h=h,
        de_mass=rng.uniform(0.5, 2.0, n), de_inertia=rng.uniform(0.01, 0.05, n),
        beta=rng.uniform(0.01, 1.0, n),
        fe_mass=rng.uniform(5.0, 20.0, 3 * nodes), fe_alpha=rng.uniform(0.01, 1.0, 3 * nodes),
        fe_fixed=rng.random(3 * nodes) < 0.1, dt=1e-3,
    ), rng


def predicted_state(ops, rng):
    n = len(ops["de_mass"])
    return rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.normal(size=ops["fe_mass"].size)


@pytest.mark.parametrize("backend", ["splu", "cholmod"])
@pytest.mark.parametrize("rotations", [True, False])
def test_full_lagrange_enforces_constraints_to_roundoff(backend, rotations):
    ops, rng = synthetic()
    cpl = Coupling(**ops, rotations=rotations, backend=backend)
    d, w, u = predicted_state(ops, rng)
    c = cpl.correct(d, w, u)
    scale = np.abs(c.gap_pred).max()
    assert np.abs(c.q - c.Gu).max() < 1e3 * EPS * scale
    # the corrected fields, recomputed from scratch, satisfy d = k u and ω = h u
    u_new = u.copy()
    u_new[c.fe_dofs] += c.du
    assert np.allclose(d + c.dd, (ops["k"] @ u_new).reshape(-1, 3), rtol=0, atol=1e3 * EPS * scale)
    if rotations:
        assert np.allclose(w + c.dw, (ops["h"] @ u_new).reshape(-1, 3), rtol=0,
                           atol=1e3 * EPS * scale)
    else:
        assert not c.dw.any()
    assert not c.du[ops["fe_fixed"][c.fe_dofs]].any(), "Dirichlet dofs must not move"


def test_multiplier_matrix_is_symmetric_positive_definite():
    ops, _ = synthetic()
    cpl = Coupling(**ops)
    S = multiplier_matrix(cpl.G, cpl.de_inv_mass, cpl.fe_inv_mass, cpl.dt).toarray()
    assert np.allclose(S, S.T, rtol=0, atol=1e-14 * np.abs(S).max())
    assert np.linalg.eigvalsh(S).min() > 0


def test_relaxation_divides_the_corrections_by_r():
    ops, rng = synthetic()
    state = predicted_state(ops, rng)
    for variant in ("full", "diagonal"):
        c1 = Coupling(**ops, variant=variant).correct(*state)
        c35 = Coupling(**ops, variant=variant, relaxation=35.0).correct(*state)
        for a, b in ((c1.dd, c35.dd), (c1.dw, c35.dw), (c1.du, c35.du)):
            assert np.allclose(a / 35.0, b, rtol=1e-13, atol=0)


def test_diagonalised_scheme_is_the_penalty_method():
    """METHOD §3.4: with p = diag(S̄)⁻¹, the diagonalised corrector equals the penalty forces
    −∂/∂q and −∂/∂u of ½ gᵀ p g evaluated at the predicted gap, integrated by central
    differences on the weighted masses (β M, β J, α m)."""
    ops, rng = synthetic()
    d, w, u = predicted_state(ops, rng)
    cpl = Coupling(**ops, variant="diagonal")
    c = cpl.correct(d, w, u)
    G = sp.vstack([ops["k"], ops["h"]]).tocsr()
    g = np.concatenate([d.ravel(), w.ravel()]) - G @ u
    p = 1.0 / cpl.solver.diagonal
    f_q, f_u = -p * g, G.T @ (p * g)  # forces from the penalty energy
    dt = ops["dt"]
    b = ops["beta"]
    dq_ref = dt**2 * f_q / np.concatenate([np.repeat(b * ops["de_mass"], 3),
                                           np.repeat(b * ops["de_inertia"], 3)])
    du_ref = np.where(ops["fe_fixed"], 0.0, dt**2 * f_u / (ops["fe_alpha"] * ops["fe_mass"]))
    assert np.allclose(np.concatenate([c.dd.ravel(), c.dw.ravel()]), dq_ref, rtol=1e-12, atol=0)
    full_du = np.zeros_like(u)
    full_du[c.fe_dofs] = c.du
    assert np.allclose(full_du, du_ref, rtol=1e-12, atol=1e-14 * np.abs(du_ref).max())


def test_diagonal_rows_are_row_sums_except_guarded_rotation_rows():
    ops, _ = synthetic()
    cpl = Coupling(**ops, variant="diagonal")
    n3 = 3 * len(ops["de_mass"])
    S = multiplier_matrix(cpl.G, cpl.de_inv_mass, cpl.fe_inv_mass, cpl.dt).tocsr()
    A, D = S[:n3, :n3], S[n3:, n3:]
    rowsum = np.concatenate([np.asarray(A.sum(1)).ravel(), np.asarray(D.sum(1)).ravel()])
    kept = rowsum >= S.diagonal()
    assert kept[:n3].all(), "translation rows (k ≥ 0) are never guarded"
    assert np.allclose(cpl.solver.diagonal[kept], rowsum[kept], rtol=1e-14)
    assert cpl.solver.guarded_rows == (~kept).sum()
    # guarded rows fall back on the absolute row sum, never below the diagonal
    assert np.all(cpl.solver.diagonal >= S.diagonal() * (1 - 1e-14))


def test_invalid_inputs_are_named():
    ops, _ = synthetic()
    with pytest.raises(ValueError, match="variant"):
        Coupling(**ops, variant="lumped")
    with pytest.raises(ValueError, match="relaxation r must be > 0, got 0"):
        Coupling(**ops, relaxation=0)
    bad = dict(ops, beta=np.where(np.arange(40) == 7, 0.0, ops["beta"]))
    with pytest.raises(ValueError, match="beta must be > 0: entry 7"):
        Coupling(**bad)


def test_weights_ramp_across_the_bridging_layers():
    br = Bridging(HalfSpaceZone([1.0, 0, 0], [-1.0, 0, 0]), layers=3, element_size=0.1)
    x = np.array([[1.05, 0, 0], [1.0, 0, 0], [0.85, 0, 0], [0.7, 0, 0], [0.5, 0, 0]])
    assert np.allclose(br.alpha(x), [0.01, 0.01, 0.5, 1.0, 1.0])
    assert np.allclose(br.beta(x), [1.0, 1.0, 0.5, 0.01, 0.01])
    assert br.contains(x).tolist() == [False, True, True, True, False]
    box = Bridging(BoxZone([0, 0, 0], [1, 1, 0.3]), layers=2, element_size=0.1)
    y = np.array([[0.5, 0.5, 0.1], [1.1, 0.5, 0.0], [1.1, 1.2, 0.3], [-0.3, 0.5, 0.2]])
    assert np.allclose(box.alpha(y), [0.01, 0.5, 1.0, 1.0])
    assert box.contains(y).tolist() == [False, True, True, False]
    with pytest.raises(ValueError, match="layers"):
        Bridging(box.zone, layers=0, element_size=0.1)


@pytest.mark.parametrize("fixed_fraction", [0.1, 1.0])
def test_full_solver_inverts_the_multiplier_matrix(fixed_fraction):
    """The Woodbury form against a dense solve of S, with both factorisation backends; with
    every FE dof fixed, S reduces to its DE diagonal."""
    ops, rng = synthetic()
    ops["fe_fixed"] = rng.random(ops["fe_mass"].size) < fixed_fraction
    cpl = Coupling(**ops)
    S = multiplier_matrix(cpl.G, cpl.de_inv_mass, cpl.fe_inv_mass, cpl.dt).toarray()
    g = rng.normal(size=S.shape[0])
    exact = np.linalg.solve(S, g)
    cond = np.linalg.cond(S)
    for backend in ("splu", "cholmod"):
        lam = FullSolver(cpl.G, cpl.de_inv_mass, cpl.fe_inv_mass, cpl.dt, backend).solve(g)
        assert np.allclose(lam, exact, rtol=0, atol=1e2 * cond * EPS * np.abs(exact).max())


@pytest.mark.parametrize("rotations", [False, True])
def test_lumping_ratio_is_the_largest_eigenvalue_of_the_lumped_against_the_full_matrix(rotations):
    """ρ = λ_max(S̄⁻¹ S) against a dense generalized eigensolve; translations alone have
    non-negative k, so the row sums dominate (Perron): ρ ≤ 1. A relaxation below ρ/2 is
    refused, one above it accepted; full Lagrange (ρ = 1) refuses r < 1/2."""
    args, _ = synthetic()
    c = Coupling(**args, variant="diagonal", rotations=rotations, relaxation=5.0)
    S = multiplier_matrix(c.G, c.de_inv_mass, c.fe_inv_mass, c.dt).toarray()
    d = c.solver.diagonal
    dense = np.linalg.eigvalsh(S / np.sqrt(np.outer(d, d)))[-1]
    assert c.lumping_ratio == pytest.approx(dense, rel=1e-6)
    if not rotations:
        assert c.lumping_ratio <= 1 + 1e-12
    with pytest.raises(ValueError, match=r"unstable: .* r < ρ/2"):
        Coupling(**args, variant="diagonal", rotations=rotations, relaxation=0.45 * dense)
    Coupling(**args, variant="diagonal", rotations=rotations, relaxation=0.55 * dense)
    with pytest.raises(ValueError, match=r"r = 0.4 makes the full coupling unstable"):
        Coupling(**args, variant="full", rotations=rotations, relaxation=0.4)


@pytest.mark.parametrize("rotations", [False, True])
def test_lumping_bound_is_gershgorins_and_spares_arpack_where_it_shows_r_stable(rotations):
    """The bound is max_i Δt² (D⁻¹_i + (|G| W⁻¹ |G|ᵀ 1)_i) / diag_i, at least the largest
    absolute row sum of diag⁻¹ S (dense), hence at least ρ; exactly 1 for translations alone
    (k ≥ 0: diag is S's row sums). With exact_ratio False, ρ is not computed where
    r ≥ bound/2, computed (and r accepted) between ρ/2 and bound/2, and r < ρ/2 refused."""
    args, _ = synthetic()
    c = Coupling(**args, variant="diagonal", rotations=rotations, relaxation=5.0)
    S = multiplier_matrix(c.G, c.de_inv_mass, c.fe_inv_mass, c.dt).toarray()
    d = c.solver.diagonal
    gershgorin = (np.abs(S).sum(axis=1) / d).max()
    assert c.lumping_bound >= gershgorin * (1 - 1e-12)
    assert c.lumping_bound >= c.lumping_ratio
    if not rotations:
        assert c.lumping_bound == pytest.approx(1.0, rel=1e-12)
        return
    assert c.lumping_bound > 1.2 * c.lumping_ratio      # room for the case between
    rho, bound = c.lumping_ratio, c.lumping_bound
    lazy = lambda r: Coupling(**args, variant="diagonal", rotations=True, relaxation=r,
                              exact_ratio=False)
    assert lazy(0.5 * bound).lumping_ratio is None
    assert lazy(0.55 * rho).lumping_ratio == pytest.approx(rho, rel=1e-12)
    with pytest.raises(ValueError, match=r"unstable: .* r < ρ/2"):
        lazy(0.45 * rho)


@pytest.mark.parametrize("rotations", [False, True])
def test_r_rho_is_the_least_relaxation_at_which_no_mode_is_over_corrected(rotations):
    """relaxation None: r = ρ, found even where the bound would spare ARPACK; then the
    corrections (1/r) S̄⁻¹ S of every constraint mode are at most 1, the largest exactly 1.
    The full solver's ρ is 1: r = 1, the constraints to round-off."""
    args, rng = synthetic()
    for exact in (True, False):
        c = Coupling(**args, variant="diagonal", rotations=rotations, relaxation=None,
                     exact_ratio=exact)
        assert c.relaxation == c.lumping_ratio
    S = multiplier_matrix(c.G, c.de_inv_mass, c.fe_inv_mass, c.dt).toarray()
    d = c.solver.diagonal
    modes = np.linalg.eigvalsh(S / np.sqrt(np.outer(d, d))) / c.relaxation
    assert modes.max() == pytest.approx(1.0, rel=1e-6) and modes.min() > 0
    full = Coupling(**args, variant="full", rotations=rotations, relaxation=None)
    assert full.relaxation == 1.0
    d0, w0, u0 = predicted_state(args, rng)
    cor = full.correct(d0, w0, u0)
    assert np.abs(cor.q - cor.Gu).max() <= 1e3 * EPS * np.abs(cor.q).max()


@pytest.mark.parametrize("r", [1.0, 2.0, 47.5])
def test_a_relaxed_coupling_lags_by_r_minus_one_steps_of_drift(r):
    """The mechanism of the relaxed coupling's compliance: spheres that drift from a held FE
    field by δ a step keep a gap that tends to (r − 1) δ, since each step removes 1/r of it:
    an interface spring of stiffness M / ((r − 1) Δt²) per sphere, none at r = 1."""
    args, rng = synthetic()
    args = dict(args, fe_fixed=np.ones_like(args["fe_fixed"]))
    c = Coupling(**args, variant="full", rotations=False, relaxation=r)
    n = len(args["de_mass"])
    drift, q, u = rng.normal(size=(n, 3)), np.zeros((n, 3)), np.zeros(args["fe_mass"].size)
    for _ in range(int(40 * r)):
        q = c.correct(q + drift, np.zeros((n, 3)), u).q.reshape(-1, 3)
    assert np.allclose(q, (r - 1) * drift, rtol=1e-9 * r, atol=1e-9 * r * np.abs(drift).max())
