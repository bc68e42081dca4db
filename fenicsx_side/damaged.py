"""The explicit FE model with concrete damage (fenicsx_side.damage_law): per cell a tension
damage and a compression damage, from the cell's average strain, that only grow and take the
cell's stiffness to its average strain on the two signs of the effective stress (a crack
closes in compression).

Cell stress on the mean strain ε̄_c: σ_c = σ̄_c − D_t σ̄⁺_c − D_c σ̄⁻_c, σ̄ = C : ε̄. The internal
force is f = K u − Sᵀ(V (D_t σ̄⁺ + D_c σ̄⁻)): PETSc's elastic mat-vec, one sparse mat-vec for
the cells' mean strains S u and one with Sᵀ, and numpy arrays of the six strain components
over the cells in between (fenicsx_side.damage_law's component-major layout), and the damaged
cells' higher-order part.
A cell's stiffness is its one-point part V B̄ᵀ C B̄ plus what the quadrature adds, K_c − V B̄ᵀ C B̄
(positive semi-definite: the strain's variation inside the cell, the cell's own bending). The
law's split takes from the first; the cell's damage D = max(D_t, D_c) scales the second, so
that a cracked cell cannot go on carrying a bending moment through it (kept whole, it held
18 % of the small-scale slab strip's bending energy with every cell at D = 1). Its force
−D K_rest,c u_c runs over the damaged cells only, their matrices (3 nv × 3 nv) made when they
first damage.
Uniform strains, and with them the law's curves in a cell, are exact. With a weight α (the
consistent bridging weighting) the means are α's, as in K, in the cells it touches. The
strain energy is ½ u·f; the energy dissipated is Σ_c V_c (½ σ̄⁺:ε̄ ΔD_t + ½ σ̄⁻:ε̄ ΔD_c)
+ ½ u_cᵀ K_rest,c u_c ΔD (energy release rates times the increments).

Serial only: a cell's strain needs its ghost nodes, which this model does not exchange.
"""
import basix
import numpy as np
import scipy.sparse as sp

from fenicsx_side.damage_law import (PAIRS, band_width, components, contract, positive_part,
                                      tensors)
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
        self._lost = np.zeros((6, n))
        self._cell_dofs = (3 * self.cell_nodes[:, :, None] + np.arange(3)).reshape(n, -1)
        self._rest = np.zeros((0,) + 2 * self._cell_dofs.shape[1:])  # of the damaged cells
        self._rest_row = np.full(n, -1)          # each cell's row there (-1: none yet)
        self._rest_cells, self._rest_count = np.zeros(0, int), 0

    def _cells_geometry(self, degree, weight):
        """Per cell: volume, centre, mean strain operators (plain, for the strain the law
        reads, and α-weighted where α ≠ 1, for the force and energy), the weighted volume,
        and the gradients at the centre for the band width."""
        X, w = basix.make_quadrature(_BASIX_CELL[self.cell_nodes.shape[1]], degree)
        xc = self._local_nodes[self.cell_nodes]                         # (n, nv, 3)
        n_cells, nq = len(xc), len(w)
        N, dN, J = self._map(np.tile(X, (n_cells, 1)), np.repeat(xc, nq, axis=0))
        grad = np.einsum("dpi,pda->pia", dN, np.linalg.inv(J)).reshape(n_cells, nq, -1, 3)
        dv = (np.abs(np.linalg.det(J)) * np.tile(w, n_cells)).reshape(n_cells, nq)
        self.cell_volume = dv.sum(axis=1)
        self.cell_centres = xc.mean(axis=1)
        mean = lambda v: np.einsum("cq,cqia->cia", v, grad) / v.sum(axis=1)[:, None, None]
        self._strain = self._strain_operator(mean(dv))
        dv_weighted, self._weighted_cells = dv, np.arange(0)
        if weight is not None:
            alpha_nodes = np.asarray(weight(self._local_nodes), float)
            dv_weighted = dv * np.einsum("pi,pi->p", N, alpha_nodes[np.repeat(
                self.cell_nodes, nq, axis=0)]).reshape(n_cells, nq)
            self._weighted_cells = np.flatnonzero((alpha_nodes[self.cell_nodes] != 1).any(1))
        self._weighted_volume = dv_weighted.sum(axis=1)
        weighted = mean(dv_weighted)
        self._quadrature = (grad, dv_weighted, weighted)   # for the cells' higher-order part
        self._weighted_strain = self._strain_operator(weighted, self._weighted_cells)
        # f = Sᵀ (V σ) with S the α-weighted strains: the shear components count twice in σ : ε
        twice = np.repeat([1.0, 1.0, 1.0, 2.0, 2.0, 2.0], n_cells)
        self._force_operator = (self._strain_operator(weighted).T @ sp.diags(twice)).tocsr()
        centre = np.tile(self._reference_centre(), (n_cells, 1))
        self._centre_grad = self._basis_at(np.arange(n_cells), centre)[1]  # (n, nv, 3)

    def _higher_order(self, cells):
        """K_c − V B̄ᵀ C B̄ of `cells` (m, 3 nv, 3 nv), dofs 3 i + a: the cells' α-weighted
        stiffness over the quadrature points, Σ_q w_q B_qᵀ C B_q (Voigt, engineering shears),
        less its one-point part."""
        grad, dv, mean_grad = (a[cells] for a in self._quadrature)
        E, nu = self.law.young, self.law.poisson
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        C = np.diag([lam + 2 * mu] * 3 + [mu] * 3)
        C[:3, :3] += lam * (1 - np.eye(3))

        def stiffness(g, w):                     # g (m, q, nv, 3), w (m, q)
            m, q, nv, _ = g.shape
            B = np.zeros((m, q, 6, nv, 3))
            for k in range(3):
                B[:, :, k, :, k] = g[:, :, :, k]
            for k, (a, b) in zip(range(3, 6), ((1, 2), (0, 2), (0, 1))):
                B[:, :, k, :, a], B[:, :, k, :, b] = g[:, :, :, b], g[:, :, :, a]
            B = B.reshape(m, q, 6, 3 * nv)
            CB = (C @ B).reshape(m, 6 * q, 3 * nv)
            Bw = (B * w[:, :, None, None]).reshape(m, 6 * q, 3 * nv)
            return Bw.transpose(0, 2, 1) @ CB
        return stiffness(grad, dv) - stiffness(mean_grad[:, None], dv.sum(axis=1)[:, None])

    def _store_rest(self, cells):
        """Store the higher-order matrices of the damaged `cells` not stored yet, in the order
        they first damage (damage never falls, so the store's cells are the damaged ones);
        the store doubles when full. Returns their rows for `cells`."""
        new = cells[self._rest_row[cells] < 0]
        if new.size:
            start = self._rest_count
            if start + new.size > len(self._rest):
                size = max(2 * len(self._rest), start + new.size)
                grown, cells_grown = np.empty((size,) + self._rest.shape[1:]), np.empty(size, int)
                grown[:start], cells_grown[:start] = self._rest[:start], self._rest_cells[:start]
                self._rest, self._rest_cells = grown, cells_grown
            self._rest[start:start + new.size] = self._higher_order(new)
            self._rest_cells[start:start + new.size] = new
            self._rest_row[new] = start + np.arange(new.size)
            self._rest_count = start + new.size
        return self._rest_row[cells]

    def _strain_operator(self, mean_grad, cells=None):
        """Sparse (6 m, ndof): u ↦ the mean strains of `cells` (default all, m of them),
        component-major (row k m + i: component PAIRS[k] of cells[i]), from mean
        shape-function gradients (n, nv, 3): ε_ab = ½ (∂u_a/∂x_b + ∂u_b/∂x_a)."""
        cells = np.arange(len(self.cell_nodes)) if cells is None else cells
        m, nodes, g = len(cells), self.cell_nodes[cells], mean_grad[cells]
        rows, cols, vals = [], [], []
        for k, (a, b) in enumerate(PAIRS):
            row = np.broadcast_to((k * m + np.arange(m))[:, None], nodes.shape)
            rows += [row, row]
            cols += [3 * nodes + a, 3 * nodes + b]
            vals += [0.5 * g[:, :, b], 0.5 * g[:, :, a]]
        return sp.csr_matrix((np.concatenate([v.ravel() for v in vals]),
                              (np.concatenate([r.ravel() for r in rows]),
                               np.concatenate([c.ravel() for c in cols]))),
                             shape=(6 * m, self.ndof))

    # --- damage -------------------------------------------------------------------------------
    def cell_strain(self):
        """The cells' mean strains (6, n_cells) of the current u."""
        return (self._strain @ self._u).reshape(6, -1)

    def update_damage(self, eps=None):
        """κ, κ_c, their ε_f and the damages from the current u (eps: its cell strains, if
        already known), and the energy the increments dissipate. Returns the split of the
        damaged cells (`split`), which the internal force of the same u reuses."""
        law = self.law
        eps = self.cell_strain() if eps is None else eps
        floor_t = np.maximum(self.kappa, law.kappa0)
        eq_t = law.tension_strain(eps, floor_t)
        eq_c = law.compression_strain(eps)
        grow_t = np.flatnonzero(eq_t > floor_t)
        grow_c = np.flatnonzero(eq_c > np.maximum(self.kappa_c, law.kappa0))
        if grow_t.size == 0 and grow_c.size == 0:
            return self.split(eps)
        for grow, eq, kappa, eps_f, softening, axis in (
                (grow_t, eq_t, self.kappa, self.eps_f, law.softening_strain, -1),
                (grow_c, eq_c, self.kappa_c, self.eps_fc, law.compressive_softening_strain, 0)):
            start = grow[np.isnan(eps_f[grow])]
            if start.size:     # band width along the principal strain that starts it
                direction = np.linalg.eigh(tensors(eps[:, start]))[1][:, :, axis]
                eps_f[start] = softening(band_width(self._centre_grad[start], direction))
            kappa[grow] = eq[grow]
        grow = np.union1d(grow_t, grow_c)
        new_t = law.damage(self.kappa[grow], self.eps_f[grow])
        new_c = law.damage(self.kappa_c[grow], self.eps_fc[grow])
        step_t, step_c = new_t - self.damage_t[grow], new_c - self.damage_c[grow]
        step = np.maximum(new_t, new_c) - self.damage[grow]
        self.damage_t[grow], self.damage_c[grow] = new_t, new_c
        self.damage[grow] = np.maximum(new_t, new_c)
        split = self.split(eps)
        hit, w, sig, pos, (u_c, rest_force) = split
        rows = self._rest_row[grow]
        self.dissipated += 0.5 * float(step @ np.einsum("ci,ci->c", u_c[rows], rest_force[rows]))
        at = np.searchsorted(hit, grow)       # grow ⊂ hit: a growing damage is > 0
        y_t = 0.5 * contract(pos[:, at], w[:, at])
        y_c = 0.5 * contract(sig[:, at] - pos[:, at], w[:, at])
        self.dissipated += float(self._weighted_volume[grow] @ (y_t * step_t + y_c * step_c))
        return split

    def split(self, eps=None):
        """(hit, ε, σ̄, σ̄⁺, (u_c, K_rest,c u_c)): the damaged cells, their (α-weighted) strains,
        effective stresses and positive parts, (6, len(hit)) each, and the cells' displacements
        and undamaged higher-order forces in the store's order (eps: all cells' plain strains,
        if already known)."""
        hit = np.flatnonzero(self.damage)
        if hit.size == 0:
            return hit, None, None, None, (None, None)
        self._store_rest(hit)
        k = self._rest_count
        u_c = self._u[self._cell_dofs[self._rest_cells[:k]]]
        rest_force = (self._rest[:k] @ u_c[:, :, None])[:, :, 0]
        eps = self.cell_strain() if eps is None else eps
        if self._weighted_cells.size:
            eps = eps.copy()
            eps[:, self._weighted_cells] = (self._weighted_strain @ self._u).reshape(6, -1)
        w = eps[:, hit]
        sig = self.law.effective_stress(w)
        return hit, w, sig, positive_part(sig), (u_c, rest_force)

    # --- forces and energies ----------------------------------------------------------------
    def internal_force(self, split=None):
        """K u − Sᵀ(V (D_t σ̄⁺ + D_c σ̄⁻)) (a buffer reused at the next call; split: the damaged
        cells' `split` of the current u, if already known)."""
        self._K_petsc.mult(self._u_vec, self._work_vec)
        self._force[:] = self._work
        hit, _, sig, pos, (_, rest_force) = self.split() if split is None else split
        if hit.size:
            self._lost[:, hit] = self._weighted_volume[hit] * (
                self.damage_t[hit] * pos + self.damage_c[hit] * (sig - pos))
            self._force -= self._force_operator @ self._lost.ravel()
            cells = self._rest_cells[:self._rest_count]
            self._force -= np.bincount(self._cell_dofs[cells].ravel(), (
                self.damage[cells, None] * rest_force).ravel(), minlength=self.ndof)
        return self._force

    def predict(self, dt):
        """The damage of u(t), then one central-difference step with the damaged force."""
        force = self.internal_force(self.update_damage())
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
        sig = components(s.tensor)
        pos = positive_part(sig)
        s.tensor = tensors(sig - self.damage_t * pos - self.damage_c * (sig - pos))
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
