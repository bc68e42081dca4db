"""The explicit FE model with concrete damage (fenicsx_side.damage_law): one damage variable per
cell, from the cell's average strain, that only grows and takes away the cell's stiffness to
its average strain.

Energy W = ½ u·K u − ½ Σ_c D_c V_c ε̄_c : C : ε̄_c, ε̄_c the cell's mean strain, so the internal
force is f = K u − Gᵀ(D V C ε̄): PETSc's elastic mat-vec, one sparse mat-vec for the cells'
mean gradients G u and one with Gᵀ, and numpy arrays over the cells in between; the cost does
not depend on how many cells are damaged. A cell's stiffness is its one-point part
V B̄ᵀ C B̄ plus what the quadrature adds (hourglass-like modes, positive semi-definite);
damage takes the first, so a cracked cell opens freely and the rest stays stable, as explicit
codes keep their hourglass control. Uniform strains, and with them the law's curve in a cell,
are exact. With a weight α (the consistent bridging weighting) the means are α's, as in K.
The energy dissipated is Σ_c ½ V_c ε̄:C:ε̄ ΔD_c (energy release rate times the increment).

Serial only: a cell's strain needs its ghost nodes, which this model does not exchange.
"""
import basix
import numpy as np
import scipy.sparse as sp

from fenicsx_side.damage_law import band_width
from fenicsx_side.model import ElasticModel

_BASIX_CELL = {4: basix.CellType.tetrahedron, 8: basix.CellType.hexahedron}


class DamageModel(ElasticModel):
    """ElasticModel with the damage law `law` (a ConcreteDamage: E and ν are its own).

    Per owned cell: kappa (history of ε_eq, 0 before any strain), eps_f (softening strain, NaN
    before damage starts), damage D, cell_volume, cell_centres; `dissipated` (J), the energy
    damage has dissipated."""
    carries_damage = True

    def __init__(self, msh, law, rho, dirichlet=(), quadrature_degree=2, weight=None):
        super().__init__(msh, law.young, law.poisson, rho, dirichlet, quadrature_degree, weight)
        if self.comm.size > 1:
            raise ValueError("FE damage runs on one rank: run the damaging model without mpirun")
        self.law = law
        self._cells_geometry(quadrature_degree, weight)
        n = len(self.cell_nodes)
        self.kappa = np.zeros(n)
        self.eps_f = np.full(n, np.nan)
        self.damage = np.zeros(n)
        self.dissipated = 0.0
        self._force = np.zeros(self.ndof)

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

    def _stress(self, eps):
        """C : ε of strain tensors (n, 3, 3)."""
        return 2 * self.mu * eps + self.lmbda * np.trace(eps, axis1=1, axis2=2)[:, None,
                                                                                None] * np.eye(3)

    def _release(self, cells, eps):
        """½ V ε̄:C:ε̄ of `cells` (α-weighted; eps: all cells' plain strains): the energy their
        damage takes per unit of D."""
        if self._weighted_gradient is not self._gradient:
            eps = self.cell_strain(self._weighted_gradient)
        eps = eps[cells]
        return 0.5 * self._weighted_volume[cells] * np.einsum("cab,cab->c", self._stress(eps),
                                                              eps)

    def update_damage(self, eps=None):
        """κ, ε_f and D from the current u (eps: its cell strains, if already known), and the
        energy the increments dissipate."""
        eps = self.cell_strain() if eps is None else eps
        floor = np.maximum(self.kappa, self.law.kappa0)
        eq = self.law.equivalent_strain(eps, floor)
        grow = np.flatnonzero(eq > floor)
        if grow.size == 0:
            return
        start = grow[np.isnan(self.eps_f[grow])]
        if start.size:         # band width along the largest principal strain, at the start
            direction = np.linalg.eigh(eps[start])[1][:, :, -1]
            self.eps_f[start] = self.law.softening_strain(
                band_width(self._centre_grad[start], direction))
        self.kappa[grow] = eq[grow]
        new = self.law.damage(self.kappa[grow], self.eps_f[grow])
        self.dissipated += float(self._release(grow, eps) @ (new - self.damage[grow]))
        self.damage[grow] = new

    # --- forces and energies ----------------------------------------------------------------
    def internal_force(self, eps=None):
        """K u − Gᵀ(D V C ε̄) (a buffer reused at the next call; eps: the cells' plain strains
        of the current u, if already known)."""
        self._K_petsc.mult(self._u_vec, self._work_vec)
        self._force[:] = self._work
        if self.damage.any():
            if eps is None or self._weighted_gradient is not self._gradient:
                eps = self.cell_strain(self._weighted_gradient)
            lost = (self.damage * self._weighted_volume)[:, None, None] * self._stress(eps)
            self._force -= self._weighted_gradient_t @ lost.ravel()
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
        """The elastic cell stresses times (1 − D)."""
        s = super().stress()
        keep = 1.0 - self.damage
        s.tensor *= keep[:, None, None]
        s.von_mises *= keep
        s.max_principal *= keep
        return s

    def take_state(self, old, nodes, cells):
        super().take_state(old, nodes, cells)
        self.kappa[:], self.eps_f[:], self.damage[:] = (old.kappa[cells], old.eps_f[cells],
                                                        old.damage[cells])
        self.dissipated = old.dissipated

    # --- history, for checkpoints -----------------------------------------------------------
    def history(self):
        return {"kappa": self.kappa, "eps_f": self.eps_f, "damage": self.damage,
                "dissipated": np.array(self.dissipated), **super().history()}

    def restore_history(self, h):
        self.kappa[:], self.eps_f[:], self.damage[:] = h["kappa"], h["eps_f"], h["damage"]
        self.dissipated = float(h["dissipated"])
        super().restore_history(h)
