"""Solvers for the Lagrange multipliers of the bridging constraints (docs/method.md, eqs. 23–28).

The multiplier system is S λ = g̃ with the constant, symmetric positive definite matrix

    S = Δt² (D⁻¹ + G W⁻¹ Gᵀ),

where G stacks the constraint operators (k, and h when rotations are coupled), D⁻¹ is the
diagonal of 1/(β M) (and 1/(β J)) per DE dof and W⁻¹ the diagonal of 1/(α m) per FE dof
(0 on Dirichlet dofs, which the constraints cannot move).
"""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def multiplier_matrix(G, de_inv_mass, fe_inv_mass, dt):
    """S = Δt² (diag(de_inv_mass) + G diag(fe_inv_mass) Gᵀ), csr."""
    GW = G @ sp.diags(fe_inv_mass)
    return (dt * dt) * (sp.diags(de_inv_mass) + GW @ G.T).tocsr()


class FullSolver:
    """Exact multipliers λ = S⁻¹ g through the Woodbury identity

        S⁻¹ = Δt⁻² [D − D G_f T⁻¹ G_fᵀ D],   T = W_f + G_fᵀ D G_f,

    with D = diag(β M, β J), W_f = diag(α m) and G_f the columns of the free FE dofs. T is a
    "coupled mass matrix" over the FE dofs of the bridging domain, with the sparsity of an FE
    mass matrix, so its Cholesky factor (computed once) is far sparser than that of S, which
    couples every pair of spheres that share an element node (measured: 2,334 bridging
    spheres with rotations, factorising S took 1.4 s and a solve 12 ms; see docs).
    """

    name = "full"

    def __init__(self, G, de_inv_mass, fe_inv_mass, dt, backend="auto"):
        self.backend = _pick_backend(backend)
        self.guarded_rows = 0
        free = fe_inv_mass > 0
        self._de_mass = 1.0 / de_inv_mass
        self._Gf = G[:, free].tocsr()
        self._inv_dt2 = 1.0 / (dt * dt)
        T = sp.diags(1.0 / fe_inv_mass[free]) + self._Gf.T @ sp.diags(self._de_mass) @ self._Gf
        self._solve_T = _FACTORISERS[self.backend](T.tocsc()) if free.any() else None

    def solve(self, g):
        Dg = self._de_mass * g
        if self._solve_T is not None:
            Dg -= self._de_mass * (self._Gf @ self._solve_T(self._Gf.T @ Dg))
        return self._inv_dt2 * Dg


class DiagonalSolver:
    """Row-sum lumped multipliers (METHOD §3.3): λ_i = g_i / Σ_j S_ij, off-diagonal blocks dropped.

    `blocks` gives the row ranges whose coupling is kept in the row sums (translations and
    rotations separately: dropping B). A row whose sum falls below its own diagonal term
    (rotation rows: h has entries of both signs) would over-correct; such rows use the
    absolute row sum instead, a Gershgorin bound that keeps the update stable.
    `guarded` lists them (row indices), `guarded_rows` counts them, `guarded_per_block` per block.

    S itself is never formed (S = Δt²(D⁻¹ + G W⁻¹ Gᵀ) couples every pair of spheres sharing
    an element node: 31 M non-zeros for 4,919 bridging spheres): row sums are two products
    with G, and the absolute row sums are needed only on guarded rows, built `chunk` rows at
    a time.
    """

    name = "diagonal"

    def __init__(self, G, de_inv_mass, fe_inv_mass, dt, blocks, chunk=500):
        G = sp.csr_matrix(G)
        dt2 = dt * dt
        diagonal = dt2 * (de_inv_mass + G.multiply(G) @ fe_inv_mass)
        self.diagonal = np.empty(G.shape[0])
        self.guarded_per_block, guarded_all = [], []
        for lo, hi in blocks:
            Gb = G[lo:hi]
            lumped = dt2 * (de_inv_mass[lo:hi] + Gb @ (fe_inv_mass * np.asarray(Gb.sum(axis=0)).ravel()))
            guarded = np.flatnonzero(lumped < diagonal[lo:hi])
            self.guarded_per_block.append(len(guarded))
            guarded_all.append(lo + guarded)
            GbW = Gb @ sp.diags(fe_inv_mass)
            for start in range(0, len(guarded), chunk):
                rows = guarded[start:start + chunk]
                coupling = abs(GbW[rows] @ Gb.T).tocsr()  # |off-diagonal + diagonal coupling terms|
                lumped[rows] = dt2 * (de_inv_mass[lo + rows] + np.asarray(coupling.sum(axis=1)).ravel())
            self.diagonal[lo:hi] = lumped
        self.guarded = np.concatenate(guarded_all) if guarded_all else np.zeros(0, int)
        self.guarded_rows = len(self.guarded)
        self._inverse = 1.0 / self.diagonal

    def solve(self, g):
        return self._inverse * g


def lumping_ratio(G, de_inv_mass, fe_inv_mass, dt, diagonal, tol=1e-6):
    """ρ = largest eigenvalue of diag⁻¹ S (S applied without forming it): how far the
    lumped multipliers over-correct the stiffest combination of constraints. The corrected
    residual is (I − S diag⁻¹ / r) times the predicted one, so a relaxation r < ρ/2 amplifies
    it every step and the run blows up (ρ = 1 for the exact S⁻¹ of full Lagrange)."""
    scale = 1.0 / np.sqrt(diagonal)
    dt2 = dt * dt

    def apply(x):  # diag^-½ S diag^-½ x
        y = scale * x
        return scale * (dt2 * (de_inv_mass * y + G @ (fe_inv_mass * (G.T @ y))))

    n = len(diagonal)
    op = spla.LinearOperator((n, n), matvec=apply, dtype=float)
    if n < 3:  # ARPACK needs n > k + 1
        return float(np.linalg.eigvalsh(np.column_stack([apply(e) for e in np.eye(n)]))[-1])
    v0 = np.full(n, 1.0 / np.sqrt(n))  # a fixed start: the same ρ every run
    return float(spla.eigsh(op, k=1, which="LA", tol=tol, v0=v0, return_eigenvectors=False)[0])


def lumping_bound(G, de_inv_mass, fe_inv_mass, dt, diagonal):
    """An upper bound of ρ (lumping_ratio) by Gershgorin's theorem on diag⁻¹ S (ρ is its
    largest eigenvalue): |S_ij| ≤ Δt² (D⁻¹_i δ_ij + Σ_k |G_ik| W⁻¹_k |G_jk|), so ρ ≤
    max_i Δt² (D⁻¹_i + (|G| W⁻¹ |G|ᵀ 1)_i) / diag_i: two products with |G| where ARPACK
    takes hundreds. Exactly 1 where G ≥ 0 (translations alone): diag is then S's row sums."""
    A = abs(G)
    rows = dt * dt * (de_inv_mass + A @ (fe_inv_mass * (A.T @ np.ones(G.shape[0]))))
    return float((rows / diagonal).max(initial=0.0))


def _pick_backend(backend):
    if backend != "auto":
        if backend not in _FACTORISERS:
            raise ValueError(f"unknown factorisation backend {backend!r}; "
                             f"choose one of {sorted(_FACTORISERS)} or 'auto'")
        return backend
    try:
        import petsc4py  # noqa: F401
        return "cholmod"
    except ImportError:
        return "splu"


def _splu(S):
    lu = spla.splu(S, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})
    return lu.solve


def _cholmod(S):
    """PETSc's CHOLMOD, serial: 4-6 ms a solve for 1,244 bridging spheres, against 7.5 ms
    (MUMPS) and 9.8 ms (scipy's splu), measured on a 2-core Debian 12 machine."""
    from petsc4py import PETSc
    S = S.tocsr()
    A = PETSc.Mat().createAIJ(size=S.shape, csr=(S.indptr, S.indices, S.data),
                              comm=PETSc.COMM_SELF)
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOperators(A)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("cholmod")
    ksp.setUp()
    b, x = A.createVecs()

    def solve(g):
        b.setArray(g)
        ksp.solve(b, x)
        return x.getArray().copy()

    return solve


_FACTORISERS = {"splu": _splu, "cholmod": _cholmod}
