"""The explicit FE model with concrete damage (fenicsx_side.damage_law): per cell a tension
damage and a compression damage, from the cell's average strain, that only grow and take the
cell's stiffness to its average strain on the two signs of the effective stress (a crack
closes in compression).

Cell stress on the mean strain ε̄_c: σ_c = σ̄_c − D_t σ̄⁺_c − D_c σ̄⁻_c, σ̄ = C : ε̄. The internal
force is f = K u − Gᵀ(V (D_t σ̄⁺ + D_c σ̄⁻)): PETSc's elastic mat-vec, one sparse mat-vec for
the cells' mean gradients G u and one with Gᵀ, and numpy arrays over the cells in between.
A cell's stiffness is its one-point part V B̄ᵀ C B̄ plus what the quadrature adds
(hourglass-like modes, positive semi-definite); damage takes from the first, so a cracked cell
opens freely and the rest stays stable, as explicit codes keep their hourglass control.
Uniform strains, and with them the law's curves in a cell, are exact. With a weight α (the
consistent bridging weighting) the means are α's, as in K. The strain energy is ½ u·f; the
energy dissipated is Σ_c V_c (½ σ̄⁺:ε̄ ΔD_t + ½ σ̄⁻:ε̄ ΔD_c) (energy release rates times the
increments).

Serial only: a cell's strain needs its ghost nodes, which this model does not exchange.
"""
import basix
import numpy as np
import scipy.sparse as sp

from fenicsx_side.damage_law import band_width, positive_part
from fenicsx_side.model import ElasticModel

_BASIX_CELL = {4: basix.CellType.tetrahedron, 8: basix.CellType.hexahedron}


class DamageModel(ElasticModel):
    """ElasticModel with the damage law `law` (a ConcreteDamage: E and ν are its own).

    Per owned cell: kappa, kappa_c (histories of the tension and compression equivalent
    strains, 0 before any strain), eps_f, eps_fc (their softening strains, NaN before that
    damage starts), damage_t, damage_c, damage (the larger of the two: a cell is broken when
    either is), cell_volume, cell_centres; `dissipated` (J), the energy damage has
    dissipated."""
    carries_damage = True
    _STATE = ("kappa", "kappa_c", "eps_f", "eps_fc", "damage_t", "damage_c", "damage")

    def __init__(self, msh, law, rho, dirichlet=(), quadrature_degree=2, weight=None):
        super().__init__(msh, law.young, law.poisson, rho, dirichlet, quadrature_degree, weight)
        if self.comm.size > 1:
            raise ValueError("FE damage runs on one rank: run the damaging model without mpirun")
        self.law = law
        self._cells_geometry(quadrature_degree, weight)
        n = len(self.cell_nodes)
        self.kappa, self.kappa_c = np.zeros(n), np.zeros(n)
        self.eps_f, self.eps_fc = np.full(n, np.nan), np.full(n, np.nan)
        self.damage_t, self.damage_c, self.damage = np.zeros(n), np.zeros(n), np.zeros(n)
        self.dissipated = 0.0
        self._force = np.zeros(self.ndof)
        self._lost = np.zeros((n, 3, 3))

    def _cells_geometry(self, degree, weight):
        """Per cell: volume, centre, mean gradients (plain, for the strain the law reads, and
        α-weighted, for the force and energy), the weighted volume, and the gradients at the
        centre for the band width."""
        X, w = basix.make_quadrature(_BASIX_CELL[self.cell_nodes.shape[1]], degree)
        xc = self._local_nodes[self.cell_nodes]                         # (n, nv, 3)
        n_cells, nq = len(xc), len(w)
        N, dN, J = self._map(np.tile(X, (n_cells, 1)), np.repeat(xc, nq, axis=0))
        grad = np.einsum("dpi,pda->pia", dN, np.linalg.inv(J)).reshape(n_cells, nq, -1, 3)
        dv = (np.abs(np.linalg.det(J)) * np.tile(w, n_cells)).reshape(n_cells, nq)
        self.cell_volume = dv.sum(axis=1)
        self.cell_centres = xc.mean(axis=1)
        mean = lambda v: np.einsum("cq,cqia->cia", v, grad) / v.sum(axis=1)[:, None, None]
        self._gradient = self._gradient_operator(mean(dv))
        dv_weighted = dv
        if weight is not None:
            alpha_nodes = np.asarray(weight(self._local_nodes), float)
            dv_weighted = dv * np.einsum("pi,pi->p", N, alpha_nodes[np.repeat(
                self.cell_nodes, nq, axis=0)]).reshape(n_cells, nq)
        self._weighted_volume = dv_weighted.sum(axis=1)
        self._weighted_gradient = (self._gradient if weight is None
                                   else self._gradient_operator(mean(dv_weighted)))
        self._weighted_gradient_t = self._weighted_gradient.T.tocsr()
        centre = np.tile(self._reference_centre(), (n_cells, 1))
        self._centre_grad = self._basis_at(np.arange(n_cells), centre)[1]  # (n, nv, 3)

    def _gradient_operator(self, mean_grad):
        """Sparse (9 n_cells, ndof): u ↦ the cells' mean displacement gradients, row 9 c + 3 a
        + b holding ∂u_a/∂x_b, from mean shape-function gradients (n, nv, 3)."""
        n, nv = self.cell_nodes.shape
        a, b = np.divmod(np.arange(9), 3)
        rows = np.broadcast_to(9 * np.arange(n)[:, None, None] + np.arange(9)[None, :, None],
                               (n, 9, nv))
        cols = 3 * self.cell_nodes[:, None, :] + a[None, :, None]
        vals = mean_grad[:, :, b].transpose(0, 2, 1)                    # (n, 9, nv)
        return sp.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())),
                             shape=(9 * n, self.ndof))

    # --- damage -------------------------------------------------------------------------------
    def cell_strain(self, operator=None):
        """Cell-average strain tensors (n_cells, 3, 3) of the current u (α-weighted averages
        with the weighted operator)."""
        g = ((self._gradient if operator is None else operator) @ self._u).reshape(-1, 3, 3)
        return 0.5 * (g + g.transpose(0, 2, 1))

    def _weighted(self, eps, cells=slice(None)):
        """The α-weighted strains of `cells` (eps: all cells' plain ones)."""
        if self._weighted_gradient is self._gradient:
            return eps[cells]
        return self.cell_strain(self._weighted_gradient)[cells]

    def update_damage(self, eps=None):
        """κ, κ_c, their ε_f and the damages from the current u (eps: its cell strains, if
        already known), and the energy the increments dissipate."""
        law = self.law
        eps = self.cell_strain() if eps is None else eps
        floor_t = np.maximum(self.kappa, law.kappa0)
        eq_t = law.tension_strain(eps, floor_t)
        eq_c = law.compression_strain(eps)
        grow_t = np.flatnonzero(eq_t > floor_t)
        grow_c = np.flatnonzero(eq_c > np.maximum(self.kappa_c, law.kappa0))
        if grow_t.size == 0 and grow_c.size == 0:
            return
        for grow, eq, kappa, eps_f, softening, axis in (
                (grow_t, eq_t, self.kappa, self.eps_f, law.softening_strain, -1),
                (grow_c, eq_c, self.kappa_c, self.eps_fc, law.compressive_softening_strain, 0)):
            start = grow[np.isnan(eps_f[grow])]
            if start.size:     # band width along the principal strain that starts it
                direction = np.linalg.eigh(eps[start])[1][:, :, axis]
                eps_f[start] = softening(band_width(self._centre_grad[start], direction))
            kappa[grow] = eq[grow]
        grow = np.union1d(grow_t, grow_c)
        new_t = law.damage(self.kappa[grow], self.eps_f[grow])
        new_c = law.damage(self.kappa_c[grow], self.eps_fc[grow])
        w = self._weighted(eps, grow)
        sig = law.effective_stress(w)
        pos = positive_part(sig)
        y_t = 0.5 * np.einsum("cab,cab->c", pos, w)
        y_c = 0.5 * np.einsum("cab,cab->c", sig - pos, w)
        self.dissipated += float(self._weighted_volume[grow] @ (
            y_t * (new_t - self.damage_t[grow]) + y_c * (new_c - self.damage_c[grow])))
        self.damage_t[grow], self.damage_c[grow] = new_t, new_c
        self.damage[grow] = np.maximum(new_t, new_c)

    # --- forces and energies ----------------------------------------------------------------
    def internal_force(self, eps=None):
        """K u − Gᵀ(V (D_t σ̄⁺ + D_c σ̄⁻)) (a buffer reused at the next call; eps: the cells'
        plain strains of the current u, if already known)."""
        self._K_petsc.mult(self._u_vec, self._work_vec)
        self._force[:] = self._work
        hit = np.flatnonzero(self.damage)
        if hit.size:
            eps = self.cell_strain() if eps is None else eps
            sig = self.law.effective_stress(self._weighted(eps, hit))
            pos = positive_part(sig)
            self._lost[hit] = self._weighted_volume[hit, None, None] * (
                self.damage_t[hit, None, None] * pos + self.damage_c[hit, None, None]
                * (sig - pos))
            self._force -= self._weighted_gradient_t @ self._lost.ravel()
        return self._force

    def predict(self, dt):
        """The damage of u(t), then one central-difference step with the damaged force."""
        eps = self.cell_strain()
        self.update_damage(eps)
        force = self.internal_force(eps)
        self._members_force(force)
        self._advance(force, dt)

    def strain_energy(self, weights=None):
        """½ Σ w u·f(u), f the damaged internal force; weights per dof (default 1); and the
        members' part."""
        w = 1.0 if weights is None else weights
        return 0.5 * float(np.sum(w * self._u * self.internal_force())) + \
            self._members_energy()

    def stress(self):
        """The cells' average stresses with the law's split of their effective stress."""
        s = super().stress()
        sig = s.tensor
        pos = positive_part(sig)
        s.tensor = sig - self.damage_t[:, None, None] * pos - self.damage_c[:, None, None] * (
            sig - pos)
        dev = s.tensor - np.trace(s.tensor, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3
        s.von_mises = np.sqrt(1.5 * np.einsum("cab,cab->c", dev, dev))
        s.max_principal = np.linalg.eigvalsh(s.tensor)[:, -1]
        return s

    def take_state(self, old, nodes, cells):
        super().take_state(old, nodes, cells)
        for name in self._STATE:
            getattr(self, name)[:] = getattr(old, name)[cells]
        self.dissipated = old.dissipated

    # --- history, for checkpoints -----------------------------------------------------------
    def history(self):
        return {**{name: getattr(self, name) for name in self._STATE},
                "dissipated": np.array(self.dissipated), **super().history()}

    def restore_history(self, h):
        for name in self._STATE:
            getattr(self, name)[:] = h[name]
        self.dissipated = float(h["dissipated"])
        super().restore_history(h)
