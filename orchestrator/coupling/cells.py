"""DE zones made of the cells of a structured grid: a zone is a boolean mask over the grid's
cells along the zone's axes (through the whole structure along the others), so that it can
take any shape the cells allow, grow cell by cell, and become a CellZone for the bridging."""
import numpy as np
from scipy.ndimage import binary_dilation

from orchestrator.coupling.bridging import CellZone


class CellGrid:
    """The grid of n[a] cells along each axis a of the box [p0, p1]; zones are masks of
    shape `shape` (the cell counts along `axes`)."""

    def __init__(self, p0, p1, n, axes=(0, 1)):
        self.p0, self.p1 = np.asarray(p0, float), np.asarray(p1, float)
        self.n = np.asarray(n, int)
        self.axes = list(axes)
        self.size = (self.p1 - self.p0) / self.n
        self.shape = tuple(int(self.n[a]) for a in self.axes)

    def check(self, mask, name="zone"):
        mask = np.asarray(mask, bool)
        if mask.shape != self.shape:
            raise ValueError(f"{name}: a mask of shape {self.shape} is needed, got {mask.shape}")
        if not mask.any():
            raise ValueError(f"{name}: no cell")
        return mask

    def boxes(self, mask):
        """(lo, hi) corners (n, 3) of the cells of `mask`, spanning the structure along the
        axes not in `axes`."""
        index = np.argwhere(self.check(mask))
        lo, hi = np.tile(self.p0, (len(index), 1)), np.tile(self.p1, (len(index), 1))
        for k, a in enumerate(self.axes):
            lo[:, a] = self.p0[a] + index[:, k] * self.size[a]
            hi[:, a] = self.p0[a] + (index[:, k] + 1) * self.size[a]
        return lo, hi

    def zone(self, mask):
        return CellZone(*self.boxes(mask), axes=self.axes)

    def index_of(self, points):
        """The index along `axes` of the cell that holds each of `points` (points on a face
        count for the cell above; points outside the box for the nearest cell)."""
        points = np.atleast_2d(points)
        return tuple(np.clip(np.floor((points[:, a] - self.p0[a]) / self.size[a]).astype(int),
                             0, self.n[a] - 1) for a in self.axes)

    def cells_of(self, points):
        """Mask of the cells that hold any of `points` (as index_of places them)."""
        mask = np.zeros(self.shape, bool)
        if len(np.atleast_2d(points)):
            mask[self.index_of(points)] = True
        return mask

    def dilate(self, mask, margin):
        """`mask` grown by `margin` cells in every direction, diagonals included (Chebyshev)."""
        if margin == 0:
            return np.asarray(mask, bool).copy()
        structure = np.ones((3,) * len(self.axes), bool)
        return binary_dilation(mask, structure, iterations=int(margin))

    def box_mask(self, lo, hi, tol=1e-9):
        """Mask of the cells inside the box [lo, hi] (3D corners; only `axes` count)."""
        mask = np.ones(self.shape, bool)
        for k, a in enumerate(self.axes):
            centres = self.p0[a] + (np.arange(self.n[a]) + 0.5) * self.size[a]
            inside = (centres > lo[a] - tol * self.size[a]) & (centres < hi[a] + tol * self.size[a])
            shape = [1] * len(self.axes)
            shape[k] = -1
            mask &= inside.reshape(shape)
        return mask
