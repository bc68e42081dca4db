"""Embedded reinforcement bars in the FE model: truss members whose nodes need not be mesh nodes.

Each bar (cases.reinforcement.Bars) is cut into truss elements of at most `element_length`;
the displacement of an element node x_j is the FE field interpolated there, u(x_j) = P u
(P: the k operator of ElasticModel.point_operators). An element a–b of axial stiffness
k = E A / L and axis t stores ½ k Δ², Δ = t·(u_b − u_a) its elongation: with Δ = G u
(G = B P, B the elongation operator of the element nodes) the bars add Gᵀ diag(k) G to K;
their mass ρ A L, lumped half to each element node, adds Pᵀ m_b to the lumped mass (P's
rows sum to 1: the total is kept exactly). The steel yields (the bars' law,
`Bars.steel_step`): each step the elements' strains ε = Δ / L update their plastic strains
ε_p, and the force K u, which holds k Δ, is corrected by −Gᵀ(k ε_p L): the element force is
k (Δ − ε_p L). Two sparse mat-vecs and numpy arrays over the elements, whatever yields.
Serial only, as the reinforced models are. In a weighted model (the bridging band's α H_FE)
each element's stiffness and mass are × α at its midpoint: ∫ α over the element when α is
linear along it (cut the bars where it is not).
"""
import numpy as np
import scipy.sparse as sp


class EmbeddedBars:
    """Truss elements of `bars` in `model` (not yet added: call add_to(model)).
    Attributes: points (m, 3) element nodes; elements (e, 2) node indices; axis (e, 3);
    length, area, young (e,); bar (e,) bar index; P (3m, ndof_global);
    stiffness (ndof_global, ndof_global) = Gᵀ diag(k) G; mass (ndof_global,) = Pᵀ m_b;
    weight (e,) α at the element midpoints (`weight(points)`, None: 1); G (e, ndof_global)
    elongations; k (e,) α E A / L; steel, the elements' plastic state (a SteelState)."""

    def __init__(self, model, bars, element_length, weight=None):
        if not element_length > 0:
            raise ValueError(f"bar element_length must be > 0, got {element_length!r}")
        pieces = np.maximum(1, np.ceil(bars.length / element_length - 1e-9).astype(int))
        points, elements, bar_of = [], [], []
        first = 0
        for i, n in enumerate(pieces):      # per bar, not per body: set-up only
            s = np.linspace(0.0, 1.0, n + 1)[:, None]
            points.append(bars.start[i] + s * (bars.end[i] - bars.start[i]))
            elements.append(first + np.column_stack([np.arange(n), np.arange(1, n + 1)]))
            bar_of.append(np.full(n, i))
            first += n + 1
        self.points = np.concatenate(points)
        self.elements = np.concatenate(elements)
        self.bar = np.concatenate(bar_of)
        d = self.points[self.elements[:, 1]] - self.points[self.elements[:, 0]]
        self.length = np.linalg.norm(d, axis=1)
        self.axis = d / self.length[:, None]
        self.area = bars.area[self.bar]
        self.young = bars.young[self.bar]
        mid = 0.5 * (self.points[self.elements[:, 0]] + self.points[self.elements[:, 1]])
        self.weight = np.ones(len(self.elements)) if weight is None else \
            np.asarray(weight(mid), float)
        self.P, _ = model.point_operators(self.points)
        self.G = (self._elongation() @ self.P).tocsr()
        self.k = self.weight * self.young * self.area / self.length
        self.stiffness = (self.G.T @ sp.diags(self.k) @ self.G).tocsr()
        self.mass = self.P.T @ self._node_masses(bars.density[self.bar])
        self.steel = bars.steel_state(self.bar, self.weight * self.area * self.length)

    def _elongation(self):
        """B (e, 3m): Δ = t·(u_b − u_a) per element from the element nodes' displacements;
        the trusses' stiffness is Bᵀ diag(k) B, k t tᵀ [[1, −1], [−1, 1]] per element."""
        e = len(self.elements)
        rows = np.repeat(np.arange(e), 6)
        cols = (3 * self.elements[:, [0, 0, 0, 1, 1, 1]] + np.tile(np.arange(3), 2)).ravel()
        vals = np.hstack([-self.axis, self.axis]).ravel()
        return sp.csr_matrix((vals, (rows, cols)), shape=(e, 3 * len(self.points)))

    def _node_masses(self, density):
        """m_b (3m,): half of each element's ρ A L at each of its nodes, on the 3 components."""
        m = np.zeros(len(self.points))
        half = 0.5 * self.weight * density * self.area * self.length
        np.add.at(m, self.elements[:, 0], half)
        np.add.at(m, self.elements[:, 1], half)
        return np.repeat(m, 3)

    def add_to(self, model):
        model.add_stiffness_and_mass(self.stiffness, self.mass, member=self)

    # --- the steel's plasticity (a member of the FE model: fenicsx_side.model) --------------
    def update(self, u_global):
        """The law at the displacement u_global (global dofs)."""
        self.steel.step((self.G @ u_global) / self.length)

    def add_force(self, force):
        """force += the correction of K u for the plastic strains (global dofs, serial)."""
        if self.steel.plastic.any():
            force -= self.G.T @ (self.k * self.steel.plastic * self.length)

    def energy_correction(self, u_global):
        """½ Σ k (Δ − Δ_p)² − ½ Σ k Δ², what ½ u·K u misses of the bars' elastic energy."""
        if not self.steel.plastic.any():
            return 0.0
        dp = self.steel.plastic * self.length
        return float(np.sum(self.k * dp * (0.5 * dp - self.G @ u_global)))

    def history(self):
        return self.steel.history()

    def restore_history(self, h):
        self.steel.restore_history(h)

    def stress(self, u_global):
        """σ = E (ε − ε_p) per element (tension > 0): the whole bar's, at u_global."""
        return self.young * ((self.G @ u_global) / self.length - self.steel.plastic)

    def axial_force(self, u_global):
        """N = A σ per element (the whole bar's: the weight shares energy, not force)."""
        return self.area * self.stress(u_global)
