"""The explicit FE model with concrete damage (fenicsx_side.damage_law): per cell a tension
damage and a compression damage, from the cell's average strain, that only grow and take the
cell's stiffness to its average strain on the two signs of the effective stress (a crack
closes in compression).

Cell stress on the mean strain ε̄_c: σ_c = σ̄_c − D_t σ̄⁺_c − D_c σ̄⁻_c, σ̄ = C : ε̄. The internal
force is f = K u − Σ_c B̄_cᵀ V_c (D_t σ̄⁺ + D_c σ̄⁻)_c: PETSc's elastic mat-vec; the cells' mean
strains B̄ u, the law's eigenvalues and the damaged cells' lost forces in one C loop each
(fenicsx_side.kernels); numpy arrays of the six strain components over the cells in between
(fenicsx_side.damage_law's component-major layout).
A cell's stiffness is its one-point part V B̄ᵀ C B̄ plus what the quadrature adds, K_c − V B̄ᵀ C B̄
(positive semi-definite: the strain's variation inside the cell, the cell's own bending). The
law's split takes from the first; the cell's damage D = max(D_t, D_c) scales the second, so
that a cracked cell cannot go on carrying a bending moment through it (kept whole, it held
18 % of the small-scale slab strip's bending energy with every cell at D = 1). Its force
−D K_rest,c u_c runs over the damaged cells only. A damaged cell's lost force is thus
(D_t σ̄⁺ + D_c σ̄⁻)_c V B̄_c + D u_c K_rest,c: cells of one shape and weighting (the unweighted
cells of a structured mesh) share V B̄ and K_rest (K_rest u_c is one matrix product per
class); any other cell gets its own when it first damages.
Uniform strains, and with them the law's curves in a cell, are exact. With a weight α (the
consistent bridging weighting) the means are α's, as in K, in the cells it touches. The
strain energy is ½ u·f; the energy dissipated is Σ_c V_c (½ σ̄⁺:ε̄ ΔD_t + ½ σ̄⁻:ε̄ ΔD_c)
+ ½ u_cᵀ K_rest,c u_c ΔD (energy release rates times the increments), each cell's term kept
per cell too (`dissipated_cells`: what yade_side.cracking is per CPM link, to sum both on one
grid).

Serial only: a cell's strain needs its ghost nodes, which this model does not exchange.
"""
import basix
import numpy as np

from fenicsx_side.damage_law import (PAIRS, band_width, components, positive_part,
                                      tensors)
from fenicsx_side.kernels import library
from fenicsx_side.model import ElasticModel

_BASIX_CELL = {4: basix.CellType.tetrahedron, 8: basix.CellType.hexahedron}
# Cells alike to this many digits share their operators (cells equal to round-off, as a
# structured mesh's are, differ in the 14th): classes of fewer than SHARED_MIN cells are not
# worth it.
SHARE_DIGITS = 9
SHARED_MIN = 8


def _apply(x, op):
    """x_c op_c for the rows of x: one matrix product with a shared op (2-D), else per row."""
    return x @ op if op.ndim == 2 else (x[:, None, :] @ op)[:, 0, :]


class DamageModel(ElasticModel):
    """ElasticModel with the damage law `law` (a ConcreteDamage: E and ν are its own).

    Per owned cell: kappa, kappa_c (histories of the tension and compression equivalent
    strains, 0 before any strain), eps_f, eps_fc (their softening strains, NaN before that
    damage starts), damage_t, damage_c, damage (the larger of the two: a cell is broken when
    either is), cell_volume, cell_centres, dissipated_cells (J, what each cell's damage has
    dissipated: α-weighted, as the energy); `dissipated` (J), the energy damage has dissipated:
    the sum of dissipated_cells (to rounding) and, after take_state, of what the cells the FE
    part gave up had dissipated (their cells are gone: the DE zone's links made in their place
    are damaged from the field's strain, and yade_side.cracking counts their energy)."""
    carries_damage = True
    _STATE = ("kappa", "kappa_c", "eps_f", "eps_fc", "damage_t", "damage_c", "damage",
              "dissipated_cells")

    def __init__(self, msh, law, rho, dirichlet=(), quadrature_degree=2, weight=None):
        super().__init__(msh, law.young, law.poisson, rho, dirichlet, quadrature_degree, weight)
        if self.comm.size > 1:
            raise ValueError("FE damage runs on one rank: run the damaging model without mpirun")
        self.law = law
        self._nodes64 = np.ascontiguousarray(self.cell_nodes, dtype=np.int64)
        self._cells_geometry(quadrature_degree, weight)
        n = len(self.cell_nodes)
        self.kappa, self.kappa_c = np.zeros(n), np.zeros(n)
        self.eps_f, self.eps_fc = np.full(n, np.nan), np.full(n, np.nan)
        self.damage_t, self.damage_c, self.damage = np.zeros(n), np.zeros(n), np.zeros(n)
        self.dissipated, self.dissipated_cells = 0.0, np.zeros(n)
        self._force = np.zeros(self.ndof)
        self._cell_dofs = (3 * self.cell_nodes[:, :, None]
                           + np.arange(3, dtype=np.int64)).reshape(n, -1)
        dofs = self._cell_dofs.shape[1]
        self._own_ops = (np.zeros((0, 6, dofs)), np.zeros((0, dofs, dofs)))  # cells of their own
        self._own_row = np.full(n, -1)          # each cell's row there (-1: none yet)
        self._own_count = 0
        self._position = np.zeros(n, int)        # a damaged cell's place in `split`'s order
        self._grouped = (np.arange(0), [])       # the last damaged cells and their `_groups`

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
        self._mean_grad = np.ascontiguousarray(mean(dv))   # the law's strains (kernels)
        dv_weighted, self._weighted_cells = dv, np.arange(0)
        alpha_nodes = None
        if weight is not None:
            alpha_nodes = np.asarray(weight(self._local_nodes), float)
            dv_weighted = dv * np.einsum("pi,pi->p", N, alpha_nodes[np.repeat(
                self.cell_nodes, nq, axis=0)]).reshape(n_cells, nq)
            self._weighted_cells = np.flatnonzero((alpha_nodes[self.cell_nodes] != 1).any(1))
        self._weighted_volume = dv_weighted.sum(axis=1)
        weighted = mean(dv_weighted)
        self._quadrature = (grad, dv_weighted, weighted)   # for the cells' higher-order part
        # the weighted cells' nodes and α-weighted mean gradients, for their strains (kernels)
        self._weighted_ops = (np.ascontiguousarray(self._nodes64[self._weighted_cells]),
                              np.ascontiguousarray(weighted[self._weighted_cells]))
        self._classes(alpha_nodes[self.cell_nodes] if weight is not None
                      else np.ones(self.cell_nodes.shape))
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

    def _lost_operators(self, cells):
        """Per cell of `cells`: its nodal force per unit lost stress, V_w B̄ (6, 3 nv) (row k:
        f_ia = V_w Σ_b ∂N_i/∂x_b σ_ab of σ the symmetric unit tensor of component PAIRS[k]),
        and its higher-order matrix (3 nv, 3 nv)."""
        g = self._quadrature[2][cells]
        m, nv, _ = g.shape
        B = np.zeros((m, 6, nv, 3))
        for k, (a, b) in enumerate(PAIRS):
            B[:, k, :, a] = g[:, :, b]
            if a != b:
                B[:, k, :, b] = g[:, :, a]
        B *= self._weighted_volume[cells, None, None, None]
        return B.reshape(m, 6, 3 * nv), self._higher_order(cells)

    def _classes(self, alpha):
        """Cells whose vertices sit alike (relative to their first, to SHARE_DIGITS digits of
        the median cell size) with alike α at them (alpha: (n, nv)) have the same operators
        (`_lost_operators`): classes of at least SHARED_MIN cells get them once, from their
        first cell. `_class_of`: each cell's class, −1 for a cell of its own; `_by_class`: the
        cells in class order, their own first."""
        xc = self._local_nodes[self.cell_nodes]
        size = np.median(np.cbrt(self.cell_volume))
        key = np.round(np.concatenate([((xc - xc[:, :1]) / size).reshape(len(xc), -1), alpha],
                                      axis=1) * 10.0 ** SHARE_DIGITS).astype(np.int64)
        _, first, inverse, counts = np.unique(key, axis=0, return_index=True,
                                              return_inverse=True, return_counts=True)
        shared = np.flatnonzero(counts >= SHARED_MIN)
        number = np.full(len(counts), -1)
        number[shared] = np.arange(shared.size)
        self._class_of = number[inverse.ravel()]
        self._by_class = np.argsort(self._class_of, kind="stable")
        self._class_ops = self._lost_operators(first[shared])

    def _own_operators(self, cells):
        """The operators of `cells` (of their own), made the first time they are asked for:
        the store keeps them in that order and doubles when full."""
        new = cells[self._own_row[cells] < 0]
        if new.size:
            start = self._own_count
            if start + new.size > len(self._own_ops[1]):
                size = max(2 * len(self._own_ops[1]), start + new.size)
                self._own_ops = tuple(np.concatenate([x[:start], np.empty((size - start,)
                                                      + x.shape[1:])]) for x in self._own_ops)
            for store, made in zip(self._own_ops, self._lost_operators(new)):
                store[start:start + new.size] = made
            self._own_row[new] = start + np.arange(new.size)
            self._own_count = start + new.size
        rows = self._own_row[cells]
        return tuple(x[rows] for x in self._own_ops)

    def _groups(self, hit):
        """The damaged cells `hit` (in class order) in groups of one class or their own:
        [(slice of hit, higher-order matrix)], shared (2-D) or per cell; the cells of their
        own get their operators (`_own_operators`), which the lost forces read."""
        bounds = np.searchsorted(self._class_of[hit], np.arange(-1, len(self._class_ops[1])),
                                 side="right")
        groups = [(slice(0, bounds[0]), self._own_operators(hit[:bounds[0]])[1])]
        for c in np.flatnonzero(np.diff(bounds)):
            groups.append((slice(bounds[c], bounds[c + 1]), self._class_ops[1][c]))
        return groups

    # --- damage -------------------------------------------------------------------------------
    def cell_strain(self):
        """The cells' mean strains (6, n_cells) of the current u."""
        eps = np.empty((6, len(self.cell_nodes)))
        library().cell_strains(len(self.cell_nodes), self.cell_nodes.shape[1], self._nodes64,
                               self._mean_grad, self._u, eps)
        return eps

    def update_damage(self):
        """κ, κ_c, their ε_f and the damages from the current u, and the energy the increments
        dissipate. Returns the split of the damaged cells (`split`), which the internal force
        of the same u reuses."""
        law, n, nu = self.law, len(self.cell_nodes), self.law.poisson
        eps = self.cell_strain()
        grow, flags = np.empty(n, np.int64), np.empty(n, np.int8)
        count = library().screen(n, eps, self.kappa, self.kappa_c, law.kappa0,
                                 nu / ((1 + nu) * (1 - 2 * nu)), nu, law.strength_ratio,
                                 np.empty(n), grow, flags)
        if count == 0:
            return self.split(eps)
        grow, flags = grow[:count], flags[:count]
        tension = np.isnan(self.eps_f[grow]) & (flags & 1 > 0)
        compression = np.isnan(self.eps_fc[grow]) & (flags & 2 > 0)
        starts = tension | compression
        if starts.any():       # band width along the principal strain that starts it
            start = grow[starts]
            vectors = np.linalg.eigh(tensors(eps[:, start]))[1]
            tension, compression = tension[starts], compression[starts]
            grad = self._centre_grad[start]
            self.eps_f[start[tension]] = law.softening_strain(
                band_width(grad[tension], vectors[tension, :, -1]))
            self.eps_fc[start[compression]] = law.compressive_softening_strain(
                band_width(grad[compression], vectors[compression, :, 0]))
        step = np.empty((3, count))
        library().grow_damage(count, grow, self.kappa, self.eps_f, self.kappa_c, self.eps_fc,
                              law.kappa0, self.damage_t, self.damage_c, self.damage, step)
        split = self.split(eps)
        hit, w, sig, pos, (u_c, rest_force, _) = split
        if hit.size:    # a growing κ gives D > 0 but for rounding just above κ₀ (no increment)
            at = self._position[grow]
            self.dissipated += library().dissipation(count, hit.size, u_c.shape[1], grow, at,
                                                     step[2], step[0], step[1], u_c, rest_force,
                                                     w, sig, pos, self._weighted_volume,
                                                     self.dissipated_cells)
        return split

    def split(self, eps=None):
        """(hit, ε, σ̄, σ̄⁺, (u_c, K_rest,c u_c, groups)): the damaged cells in class order, their
        (α-weighted) strains, effective stresses and positive parts (6, len(hit)), their
        displacements and undamaged higher-order forces (len(hit), 3 nv), and `_groups`
        (eps: all cells' plain strains, if already known)."""
        hit = self._by_class[self.damage[self._by_class] > 0]
        if hit.size == 0:
            return hit, None, None, None, (None, None, None)
        if not np.array_equal(hit, self._grouped[0]):   # damage grows: mostly the same cells
            self._position[hit] = np.arange(hit.size)
            self._grouped = (hit, self._groups(hit))
        groups = self._grouped[1]
        eps = self.cell_strain() if eps is None else eps
        w = eps.take(hit, axis=1)           # C order, as the kernels take it
        if self._weighted_cells.size:
            weighted = np.empty((6, self._weighted_cells.size))
            library().cell_strains(weighted.shape[1], self.cell_nodes.shape[1],
                                   *self._weighted_ops, self._u, weighted)
            hit_weighted = self.damage[self._weighted_cells] > 0
            w[:, self._position[self._weighted_cells[hit_weighted]]] = weighted[:, hit_weighted]
        m, dofs = hit.size, self._cell_dofs.shape[1]
        sig, pos, u_c = np.empty((6, m)), np.empty((6, m)), np.empty((m, dofs))
        library().split_cells(m, dofs, hit, self._cell_dofs, self._u, w, self.law.young,
                              self.law.poisson, sig, pos, u_c)
        rest_force = np.empty_like(u_c)
        for rows, rest in groups:
            rest_force[rows] = _apply(u_c[rows], rest)
        return hit, w, sig, pos, (u_c, rest_force, groups)

    # --- forces and energies ----------------------------------------------------------------
    def internal_force(self, split=None):
        """K u less the damaged cells' lost forces, V_w B̄ᵀ (D_t σ̄⁺ + D_c σ̄⁻) + D K_rest u_c (a
        buffer reused at the next call; split: the damaged cells' `split` of the current u,
        if already known)."""
        self._K_petsc.mult(self._u_vec, self._work_vec)
        self._force[:] = self._work
        hit, _, sig, pos, (_, rest_force, _) = self.split() if split is None else split
        if hit.size:
            force_ops, own_ops = self._class_ops[0], self._own_ops[0]
            library().lost_forces(hit.size, self._cell_dofs.shape[1], hit, self._cell_dofs, sig,
                                  pos, self.damage_t, self.damage_c, self.damage, rest_force,
                                  self._class_of, force_ops, self._own_row, own_ops, self._force)
        return self._force

    def predict(self, dt):
        """The damage of u(t), then one central-difference step with the damaged force."""
        force = self.internal_force(self.update_damage())
        self._members_force(force)
        self._advance(force, dt)

    def nodal_strain_energy(self):
        """½ u_i f_i(u) per dof, f the damaged internal force (strain_energy sums it)."""
        return 0.5 * self._u * self.internal_force()

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

    def compaction_at(self, points):
        """The compaction tensors (n, 3, 3) of the cells containing `points`
        (ConcreteDamage.compaction of their mean strains); 0 at a point in no cell."""
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        found, cells, _ = self._locate_owned(points)
        out = np.zeros((len(points), 3, 3))
        out[found] = tensors(self.law.compaction(self.cell_strain()[:, cells],
                                                 self.damage_c[cells]))
        return out

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
