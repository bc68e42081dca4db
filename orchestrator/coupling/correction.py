"""One coupling correction per time step (docs/method.md, eqs. 14–28 and 33–35).

Both partners first advance alone (the predictor: α and β cancel there). Given the predicted
displacements and rotations of the bridging spheres and the predicted FE displacement, the
coupling returns the corrections that enforce (full), or relax (diagonal, r > 1), the
constraints d = k u and ω = h u. Pure numpy/scipy: arrays in, arrays out.
"""
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from orchestrator.coupling.multipliers import (DiagonalSolver, FullSolver, lumping_bound,
                                               lumping_ratio)

VARIANTS = ("full", "diagonal")


@dataclass
class Correction:
    dd: np.ndarray        # (n, 3) sphere displacement corrections
    dw: np.ndarray        # (n, 3) sphere rotation corrections (zeros when rotations are off)
    fe_dofs: np.ndarray   # FE dofs touched by the coupling
    du: np.ndarray        # corrections of u[fe_dofs]
    force: np.ndarray     # multiplier forces λ/r, translations then rotations (3n or 6n)
    fe_force: np.ndarray  # Gᵀ force on fe_dofs
    gap_pred: np.ndarray  # constraint residual q̃ − G ũ of the predictor
    q: np.ndarray         # corrected sphere dofs (d, then ω), flat
    u: np.ndarray         # corrected FE displacement on fe_dofs
    G: sp.csr_matrix      # the constraint operator on fe_dofs

    @property
    def Gu(self):
        """G u of the corrected FE field (the residual is q − Gu); on demand, not every step."""
        return self.G @ self.u

    def gaps(self):
        """Largest constraint residual before and after the correction, relative to the
        largest sphere dof (0 when nothing moves): the coupling's health at a glance."""
        scale = np.abs(self.q).max(initial=0.0)
        if scale == 0:
            return 0.0, 0.0
        return (float(np.abs(self.gap_pred).max()) / scale,
                float(np.abs(self.q - self.Gu).max()) / scale)


class Coupling:
    """Bridging-domain coupling of n spheres to an FE field of `fe_mass.size` dofs.

    k, h: (3n, ndof) sparse operators of docs/method.md (h may be None when rotations are off);
    de_mass, de_inertia, beta: (n,); fe_mass, fe_alpha: (ndof,) lumped mass and α per dof;
    fe_fixed: (ndof,) mask of Dirichlet dofs; dt: the common time step; relaxation: r, or
    None for r = ρ. The diagonal solver's stability is checked on ρ (lumping_ratio, ARPACK);
    with exact_ratio False, on its bound first (lumping_bound) and ρ is found only where the
    bound does not show r stable (lumping_ratio None: not computed).
    """

    def __init__(self, k, h, de_mass, de_inertia, beta, fe_mass, fe_alpha, fe_fixed, dt,
                 variant="full", relaxation=1.0, rotations=True, backend="auto",
                 exact_ratio=True):
        if variant not in VARIANTS:
            raise ValueError(f"coupling variant must be one of {VARIANTS}, got {variant!r}")
        if relaxation is not None and not relaxation > 0:
            raise ValueError(f"relaxation r must be > 0, got {relaxation!r}")
        if not dt > 0:
            raise ValueError(f"time step must be > 0, got {dt!r}")
        n = len(de_mass)
        if k.shape[0] != 3 * n or (rotations and h.shape[0] != 3 * n):
            raise ValueError(f"k and h need {3 * n} rows for {n} spheres, got {k.shape}, "
                             f"{None if h is None else h.shape}")
        _check_positive("beta", beta)
        _check_positive("sphere mass", de_mass)
        if rotations:
            _check_positive("sphere inertia", de_inertia)
        self.n = n
        self.dt = float(dt)
        self.variant = variant
        self.relaxation = None if relaxation is None else float(relaxation)
        self.rotations = bool(rotations)

        G = sp.vstack([k, h]).tocsr() if rotations else sp.csr_matrix(k)
        self.fe_dofs = np.unique(G.indices)
        self.G = G[:, self.fe_dofs].tocsr()
        fe_w = np.asarray(fe_alpha, float)[self.fe_dofs] * np.asarray(fe_mass, float)[self.fe_dofs]
        _check_positive("alpha * FE mass of coupled dofs", fe_w)
        self.fe_inv_mass = np.where(np.asarray(fe_fixed, bool)[self.fe_dofs], 0.0, 1.0 / fe_w)
        de_inv = [np.repeat(1.0 / (beta * de_mass), 3)]
        if rotations:
            de_inv.append(np.repeat(1.0 / (beta * de_inertia), 3))
        self.de_inv_mass = np.concatenate(de_inv)

        if variant == "full":
            self.solver = FullSolver(self.G, self.de_inv_mass, self.fe_inv_mass, self.dt, backend)
        else:
            blocks = [(0, 3 * n), (3 * n, 6 * n)] if rotations else [(0, 3 * n)]
            self.solver = DiagonalSolver(self.G, self.de_inv_mass, self.fe_inv_mass, self.dt,
                                         blocks)
        # rotation rows whose lumped multiplier fell back on the absolute row sum (the diagonal
        # solver's stability guard): on those the rotation constraint is enforced more weakly
        guarded = (self.solver.guarded[self.solver.guarded >= 3 * n]
                   if variant == "diagonal" and rotations else np.zeros(0, int))
        self.guarded_rotation_rows = len(guarded)
        self.guarded_rotation_spheres = np.unique((guarded - 3 * n) // 3)  # their spheres
        # ρ's Gershgorin bound; ARPACK's ρ itself only where it is asked for or the bound
        # cannot show r stable
        self.lumping_bound, self.lumping_ratio = 1.0, 1.0
        if variant != "full":
            args = self.G, self.de_inv_mass, self.fe_inv_mass, self.dt, self.solver.diagonal
            self.lumping_bound = lumping_bound(*args)
            bounded = (not exact_ratio and self.relaxation is not None
                       and self.relaxation >= 0.5 * self.lumping_bound)
            self.lumping_ratio = None if bounded else lumping_ratio(*args)
        if self.relaxation is None:
            # r = ρ: the least relaxation at which the lumped correction exceeds the full one
            # in no constraint mode (the full solver's ρ is 1: r = 1, the constraints exactly)
            self.relaxation = float(self.lumping_ratio)
        if self.lumping_ratio is not None and self.relaxation < 0.5 * self.lumping_ratio:
            raise ValueError(
                f"relaxation r = {relaxation!r} makes the {variant} coupling unstable: its "
                f"corrections over-shoot the constraints when r < ρ/2 = "
                f"{0.5 * self.lumping_ratio:.4g} (ρ = {self.lumping_ratio:.4g}, the largest "
                f"eigenvalue of the lumped against the full multiplier matrix); take a larger r")

    def correct(self, d, w, u):
        """Corrections for predicted sphere displacements d (n,3), rotations w (n,3) and FE
        displacement u (ndof,)."""
        q = np.asarray(d, float).ravel()
        if self.rotations:
            q = np.concatenate([q, np.asarray(w, float).ravel()])
        u = u[self.fe_dofs]
        gap_pred = q - self.G @ u
        lam = self.solver.solve(gap_pred)
        scale = self.dt * self.dt / self.relaxation
        dq = -scale * self.de_inv_mass * lam
        GTlam = self.G.T @ lam
        du = scale * self.fe_inv_mass * GTlam
        n3 = 3 * self.n
        dw = dq[n3:].reshape(-1, 3) if self.rotations else np.zeros((self.n, 3))
        return Correction(dq[:n3].reshape(-1, 3), dw, self.fe_dofs, du, lam / self.relaxation,
                          GTlam / self.relaxation, gap_pred, q + dq, u + du, self.G)


def _check_positive(name, values):
    values = np.asarray(values, float)
    bad = np.flatnonzero(~(values > 0))
    if bad.size:
        raise ValueError(f"{name} must be > 0: entry {bad[0]} is {values[bad[0]]!r}")
