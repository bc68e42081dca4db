"""Bridging-domain geometry and the energy weights α (FE nodes) and β (spheres).

The DE zone is where only spheres live; the bridging domain is the band of `n_b` FE element
layers just outside it, of width `n_b · h`. A zone gives each point its depth `s` out of the
DE zone (s < 0 inside it): α rises linearly from 0 at s = 0 to 1 at s = width, β = 1 − α,
both clamped to at least 0.01 because the corrector divides by them (docs/method.md, eq. 2).
"""
import numpy as np

WEIGHT_FLOOR = 0.01
# How α and β enter the models: "nodal" (the paper's: they weigh the multipliers only) or
# "consistent" (inside each partner's masses and stiffnesses: energy-conserving).
WEIGHTINGS = ("nodal", "consistent")


def check_weighting(owner, weighting):
    if weighting not in WEIGHTINGS:
        raise ValueError(f"{owner}: weighting must be one of {WEIGHTINGS}, got {weighting!r}")


class Zone:
    """A DE zone: depth(x) of points (n, 3) out of it (negative inside)."""

    def within(self, x, distance):
        """Mask of the points x no deeper out of the zone than `distance`."""
        return self.depth(x) <= distance


class HalfSpaceZone(Zone):
    """DE zone {x : (x − point)·normal < 0}: a plane interface, `normal` pointing to the FE side."""

    def __init__(self, point, normal):
        self.point = np.asarray(point, float)
        n = np.asarray(normal, float)
        norm = np.linalg.norm(n)
        if norm == 0:
            raise ValueError("HalfSpaceZone: normal must be non-zero")
        self.normal = n / norm

    def depth(self, x):
        return (np.atleast_2d(x) - self.point) @ self.normal


class BoxZone(Zone):
    """Axis-aligned box DE zone, through the whole structure along the axes not in `axes`.

    The depth is the Chebyshev distance out of the box over `axes`, so the bridging layers are
    box-shaped shells that follow element boundaries of a structured mesh; negative inside.
    """

    def __init__(self, lo, hi, axes=(0, 1)):
        self.lo = np.asarray(lo, float)
        self.hi = np.asarray(hi, float)
        self.axes = list(axes)
        if np.any(self.hi[self.axes] <= self.lo[self.axes]):
            raise ValueError(f"BoxZone: hi {self.hi} must exceed lo {self.lo} along axes {self.axes}")

    def depth(self, x):
        x = np.atleast_2d(x)[:, self.axes]
        out = np.maximum(self.lo[self.axes] - x, x - self.hi[self.axes])
        return out.max(axis=1)


class CellZone(Zone):
    """DE zone made of axis-aligned cells (a union of boxes, e.g. FE cells of a structured
    grid), through the whole structure along the axes not in `axes`; lo, hi: (n_cells, 3)
    corners. The depth is the smallest of the cells' BoxZone depths: outside the zone it is
    the Chebyshev distance to the union over `axes` (so the band is the cell layers around
    it); inside it is negative (for several cells not the distance to the zone's boundary).
    One cell gives exactly BoxZone's depth.
    """
    CHUNK = 1 << 21     # points × cells × axes per block of the depth computation
    NEAREST = 4         # cells whose exact depth is taken, where a tree finds the nearest (4:
                        # a corner's ties)

    def __init__(self, lo, hi, axes=(0, 1)):
        self.lo = np.atleast_2d(np.asarray(lo, float))
        self.hi = np.atleast_2d(np.asarray(hi, float))
        self.axes = list(axes)
        if self.lo.shape != self.hi.shape or self.lo.shape[1:] != (3,) or not len(self.lo):
            raise ValueError(f"CellZone: lo and hi must be (n >= 1, 3) arrays of corners, got "
                             f"shapes {self.lo.shape} and {self.hi.shape}")
        if np.any(self.hi[:, self.axes] <= self.lo[:, self.axes]):
            raise ValueError(f"CellZone: every cell's hi must exceed its lo along axes {self.axes}")
        self._lo, self._hi = self.lo[:, self.axes], self.hi[:, self.axes]
        # cells of one size, equal along the axes: a cell's depth is its centre's Chebyshev
        # distance less the half-size, so a tree finds the few cells that can be the nearest
        size = self._hi - self._lo
        self._tree = None
        if len(self._lo) > self.NEAREST and np.allclose(size, size[0, 0], rtol=1e-12, atol=0):
            from scipy.spatial import cKDTree
            self._tree = cKDTree(0.5 * (self._lo + self._hi))

    def within(self, x, distance):
        # the depth is at least the Chebyshev distance out of the cells' bounding box: only
        # the points that near are looked up (a grown zone scans its whole packing)
        x = np.atleast_2d(x)
        p = x[:, self.axes]
        near = np.maximum(self._lo.min(axis=0) - p, p - self._hi.max(axis=0)).max(axis=1) \
            <= distance
        out = np.zeros(len(x), bool)
        out[near] = self.depth(x[near]) <= distance
        return out

    def depth(self, x):
        x = np.atleast_2d(x)[:, self.axes]
        if self._tree is not None:      # the exact depth over the tree's nearest cells
            near = self._tree.query(x, k=self.NEAREST, p=np.inf)[1]
            p = x[:, None, :]
            return np.maximum(self._lo[near] - p, p - self._hi[near]).max(axis=2).min(axis=1)
        out = np.empty(len(x))
        step = max(1, self.CHUNK // (len(self._lo) * len(self.axes)))
        for start in range(0, len(x), step):
            p = x[start:start + step, None, :]
            d = np.maximum(self._lo - p, p - self._hi).max(axis=2)
            out[start:start + step] = d.min(axis=1)
        return out


class Bridging:
    """A DE zone plus a bridging band of `layers` FE element layers of size `element_size`."""

    def __init__(self, zone, layers, element_size):
        if int(layers) != layers or layers < 1:
            raise ValueError(f"bridging layers must be an integer >= 1, got {layers!r}")
        if not element_size > 0:
            raise ValueError(f"bridging element size must be > 0, got {element_size!r}")
        self.zone = zone
        self.layers = int(layers)
        self.width = self.layers * float(element_size)

    def _ramp(self, x):
        return np.clip(self.zone.depth(x) / self.width, 0.0, 1.0)

    def alpha(self, x):
        """FE weight at points x: 1 outside the bridging domain."""
        return np.maximum(self._ramp(x), WEIGHT_FLOOR)

    def beta(self, x):
        """DE weight at points x: 1 inside the DE zone."""
        return np.maximum(1.0 - self._ramp(x), WEIGHT_FLOOR)

    def share(self, x):
        """The FE's share of the band at points x, α without its floor (0 in the DE zone, 1
        outside the band): with 1 − share for the spheres, a partition of unity that adds up
        what both models hold."""
        return self._ramp(x)

    def covers(self, x):
        """Mask of the points of a coupled model's DE part: the DE zone and the band."""
        return self.zone.within(x, self.width)

    def contains(self, x, tol=0.0):
        """Mask of the points in the bridging domain (0 ≤ s ≤ width, widened by tol)."""
        s = self.zone.depth(x)
        return (s >= -tol) & (s <= self.width + tol)
