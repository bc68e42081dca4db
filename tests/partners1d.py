"""Pure-numpy stand-ins for the two partners, in 1D along x (test cross-checks only).

They follow the partner protocols of orchestrator.stepper with 3 dofs per node/sphere, of
which only x moves: a chain of point masses and springs (the DE side) and a lumped linear
bar (the FE side).
"""
import numpy as np
import scipy.sparse as sp


def _stiffness_1d(n_points, stiffness):
    """Spring chain stiffness on x dofs (3 per point); stiffness[i] links points i, i+1."""
    i = np.arange(n_points - 1)
    rows = np.concatenate([i, i + 1, i, i + 1])
    cols = np.concatenate([i, i + 1, i + 1, i])
    vals = np.concatenate([stiffness, stiffness, -stiffness, -stiffness])
    K1 = sp.csr_matrix((vals, (rows, cols)), shape=(n_points, n_points))
    P = sp.csr_matrix((np.ones(n_points), (3 * np.arange(n_points), np.arange(n_points))),
                      shape=(3 * n_points, n_points))
    return (P @ K1 @ P.T).tocsr()


class Bar:
    """Lumped linear FE bar on [x0, x0 + n h] (E, A, ρ); y and z dofs are fixed."""

    def __init__(self, x0, h, n, E, A, rho):
        self.nodes = np.zeros((n + 1, 3))
        self.nodes[:, 0] = x0 + h * np.arange(n + 1)
        self.h, self.x0 = h, x0
        m = np.full(n + 1, rho * A * h)
        m[[0, -1]] *= 0.5
        self.mass = np.repeat(m, 3)
        self.K = _stiffness_1d(n + 1, np.full(n, E * A / h))
        self.fixed = np.ones(3 * (n + 1), bool)
        self.fixed[0::3] = False
        self.u = np.zeros(3 * (n + 1))
        self.v = np.zeros_like(self.u)

    def predict(self, dt):
        self.v += dt * (-(self.K @ self.u) / self.mass)
        self.v[self.fixed] = 0.0
        self.u += dt * self.v

    def correct(self, dofs, du, dt):
        self.u[dofs] += du
        self.v[dofs] += du / dt

    def point_operators(self, x):
        """k: linear interpolation of u at x; h: zero (no rotations in 1D)."""
        e = np.clip(((x[:, 0] - self.x0) // self.h).astype(int), 0, len(self.nodes) - 2)
        xi = (x[:, 0] - self.nodes[e, 0]) / self.h
        j, c, a = np.meshgrid(np.arange(len(x)), np.arange(3), np.arange(2), indexing="ij")
        N = np.stack([1 - xi, xi], axis=1)  # (n, 2) hat functions of the element's nodes
        rows, cols, vals = 3 * j + c, 3 * (e[j] + a) + c, N[j, a]
        k = sp.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())),
                          shape=(3 * len(x), self.u.size))
        return k, sp.csr_matrix(k.shape)


class Chain:
    """Point masses m at x0 + i L linked by springs k; `bridge(idx)` gives a bridge view."""

    def __init__(self, x0, L, n, m, k):
        self.pos0 = np.zeros((n, 3))
        self.pos0[:, 0] = x0 + L * np.arange(n)
        self.mass = np.full(n, m)
        self.K = _stiffness_1d(n, np.full(n - 1, k))
        self.d = np.zeros(3 * n)
        self.v = np.zeros(3 * n)
        self.dt = None

    def step(self):
        self.v += self.dt * (-(self.K @ self.d) / np.repeat(self.mass, 3))
        self.d += self.dt * self.v

    def bridge(self, idx):
        return ChainBridge(self, np.asarray(idx))


class ChainBridge:
    def __init__(self, chain, idx):
        self.chain, self.idx = chain, idx
        self.dofs = (3 * idx[:, None] + np.arange(3)).ravel()
        self.mass = chain.mass[idx]
        self.inertia = np.ones(len(idx))
        self.rotation_pred = np.zeros((len(idx), 3))

    def predict(self, dt):
        pass

    def displacement(self):
        return self.chain.d[self.dofs].reshape(-1, 3)

    def correct(self, dd, dw, dt):
        self.chain.d[self.dofs] += dd.ravel()
        self.chain.v[self.dofs] += dd.ravel() / dt
