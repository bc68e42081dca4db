"""Embedded reinforcement bars in the FE model: truss members whose nodes need not be mesh nodes.

Each bar (cases.reinforcement.Bars) is cut into truss elements of at most `element_length`;
the displacement of an element node x_j is the FE field interpolated there, u(x_j) = P u
(P: the k operator of ElasticModel.point_operators). An element a–b of axial stiffness
k = E A / L and axis t stores ½ k (t·(u_b − u_a))², so the bars add Pᵀ K_b P to K, with K_b the
block-diagonal truss stiffness of the element nodes; their mass ρ A L, lumped half to each
element node, adds Pᵀ m_b to the lumped mass (P's rows sum to 1: the total is kept exactly).
The bars are linear elastic: `yielded` tells where |σ| passes fy, the model does not yield.
In a weighted model (the bridging band's α H_FE) each element's stiffness and mass are × α at
its midpoint: ∫ α over the element when α is linear along it (cut the bars where it is not).
"""
import warnings

import numpy as np
import scipy.sparse as sp


class EmbeddedBars:
    """Truss elements of `bars` in `model` (not yet added: call add_to(model)).
    Attributes: points (m, 3) element nodes; elements (e, 2) node indices; axis (e, 3);
    length, area, young, yield_strength (e,); bar (e,) bar index; P (3m, ndof_global);
    stiffness (ndof_global, ndof_global) = Pᵀ K_b P; mass (ndof_global,) = Pᵀ m_b;
    weight (e,) α at the element midpoints (`weight(points)`, None: 1)."""

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
        self.yield_strength = bars.yield_strength[self.bar]
        mid = 0.5 * (self.points[self.elements[:, 0]] + self.points[self.elements[:, 1]])
        self.weight = np.ones(len(self.elements)) if weight is None else \
            np.asarray(weight(mid), float)
        self.P, _ = model.point_operators(self.points)
        self.stiffness = (self.P.T @ self._truss_stiffness() @ self.P).tocsr()
        self.mass = self.P.T @ self._node_masses(bars.density[self.bar])

    def _truss_stiffness(self):
        """K_b over the element nodes' dofs (3m square): k t tᵀ [[1, −1], [−1, 1]] per element."""
        k = self.weight * self.young * self.area / self.length
        block = k[:, None, None] * np.einsum("ei,ej->eij", self.axis, self.axis)   # (e, 3, 3)
        rows, cols, vals = [], [], []
        for p, q, sign in ((0, 0, 1), (0, 1, -1), (1, 0, -1), (1, 1, 1)):
            r = 3 * self.elements[:, p, None, None] + np.arange(3)[None, :, None]
            c = 3 * self.elements[:, q, None, None] + np.arange(3)[None, None, :]
            rows.append(np.broadcast_to(r, block.shape).ravel())
            cols.append(np.broadcast_to(c, block.shape).ravel())
            vals.append(sign * block.ravel())
        n = 3 * len(self.points)
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(n, n))

    def _node_masses(self, density):
        """m_b (3m,): half of each element's ρ A L at each of its nodes, on the 3 components."""
        m = np.zeros(len(self.points))
        half = 0.5 * self.weight * density * self.area * self.length
        np.add.at(m, self.elements[:, 0], half)
        np.add.at(m, self.elements[:, 1], half)
        return np.repeat(m, 3)

    def add_to(self, model):
        model.add_stiffness_and_mass(self.stiffness, self.mass)

    def axial_force(self, u_global):
        """N = k t·(u_b − u_a) per element (tension > 0), u_global the FE displacement over
        global dofs."""
        u = (self.P @ u_global).reshape(-1, 3)
        du = u[self.elements[:, 1]] - u[self.elements[:, 0]]
        return self.young * self.area / self.length * np.einsum("ei,ei->e", self.axis, du)

    def yield_ratio(self, u_global):
        """|σ| / fy per element (σ = N/A of the whole bar: the weight shares energy, not
        stress)."""
        return np.abs(self.axial_force(u_global)) / (self.area * self.yield_strength)

    def yielded(self, u_global, warn=True):
        """Elements whose |σ| = |N|/A exceeds fy (the model stays elastic there); warns."""
        stress = self.axial_force(u_global) / self.area
        over = np.flatnonzero(np.abs(stress) > self.yield_strength)
        if warn and over.size:
            worst = over[np.argmax(np.abs(stress[over]) / self.yield_strength[over])]
            warnings.warn(f"FE bars: {over.size} of {len(stress)} elements past the yield "
                          f"strength (worst {stress[worst] / 1e6:.0f} MPa, fy "
                          f"{self.yield_strength[worst] / 1e6:.0f} MPa, bar {self.bar[worst]}): "
                          f"the bars are elastic, their forces there are overestimated")
        return over
