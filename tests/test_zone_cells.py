"""DE zones made of grid cells: their depth, the grid's masks, and the FE mesh less the cells."""
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from fenicsx_side.cells import box_mesh_without_cells
from orchestrator.coupling.bridging import BoxZone, Bridging, CellZone
from orchestrator.coupling.cells import CellGrid

P0, P1, N = (0.0, 0.0, 0.0), (2.5, 2.0, 0.28), (10, 8, 2)


def random_points(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.5, 1.0, (n, 3)) * np.array([2.5, 2.0, 0.28]) + [0.0, 0.0, 0.0]


def test_one_cell_is_exactly_the_box():
    lo, hi = np.array([0.7, 0.4, 0.0]), np.array([1.3, 1.1, 0.28])
    x = random_points(20000)
    for axes in [(0, 1), (0,), (0, 1, 2)]:
        assert np.array_equal(CellZone(lo, hi, axes).depth(x), BoxZone(lo, hi, axes).depth(x))


def test_union_depth_is_the_chebyshev_distance_outside():
    """Outside an L-shaped union of cells the depth is the L∞ distance to it (brute force
    over a fine sample of the union); inside it is negative."""
    grid = CellGrid(P0, P1, N)
    mask = np.zeros(grid.shape, bool)
    mask[3:6, 2:4] = True
    mask[3:4, 4:7] = True
    zone = grid.zone(mask)
    x = random_points(3000, seed=1)
    d = zone.depth(x)
    lo, hi = grid.boxes(mask)
    inside = np.any(np.all((x[:, None, :2] >= lo[None, :, :2]) & (x[:, None, :2] <= hi[None, :, :2]),
                           axis=2), axis=1)
    assert np.all(d[inside] <= 0) and np.all(d[~inside] > 0)
    # L∞ distance to a union of boxes = the smallest L∞ distance to one of them
    gap = np.maximum(np.maximum(lo[None, :, :2] - x[:, None, :2], x[:, None, :2] - hi[None, :, :2]),
                     0).max(axis=2).min(axis=1)
    assert np.array_equal(d[~inside], gap[~inside])
    # chunking changes nothing
    small = CellZone(lo, hi)
    small.CHUNK = 7
    assert np.array_equal(small.depth(x), d)
    # within(x, s) is depth <= s, through the bounding box's cut (which leaves out part of
    # the sample at the smaller s): inside the union, at its boundary, out past the sample
    box = np.maximum(lo.min(axis=0)[:2] - x[:, :2], x[:, :2] - hi.max(axis=0)[:2]).max(axis=1)
    assert (box > 0.1).sum() > 1000
    for s in (-0.1, 0.0, 0.1, 0.25, 0.6, 3.0):
        assert np.array_equal(zone.within(x, s), d <= s)


def test_band_is_the_cell_layers_around_the_zone():
    """With a band of 2 cell layers, α = 1 at cell centres ≥ 2 cells away (L∞), the ramp is
    linear in between: cell centres at distance k cells + ½ get α = (k + ½)/2."""
    grid = CellGrid(P0, P1, N)
    mask = np.zeros(grid.shape, bool)
    mask[4:6, 3:5] = True
    mask[6, 3] = True
    b = Bridging(grid.zone(mask), 2, grid.size[0])
    ii, jj = np.meshgrid(np.arange(N[0]), np.arange(N[1]), indexing="ij")
    centres = np.column_stack([(ii.ravel() + 0.5) * grid.size[0], (jj.ravel() + 0.5) * grid.size[1],
                               np.full(ii.size, 0.1)])
    # cell distance (Chebyshev, in cells) of each cell to the zone's cells
    zi = np.argwhere(mask)
    k = np.abs(np.stack([ii.ravel(), jj.ravel()], 1)[:, None] - zi[None]).max(axis=2).min(axis=1)
    alpha = b.alpha(centres)
    assert np.allclose(alpha[k == 0], 0.01)
    assert np.allclose(alpha[k == 1], 0.5 / 2, rtol=1e-12)
    assert np.allclose(alpha[k == 2], 1.5 / 2, rtol=1e-12)
    assert np.all(alpha[k >= 3] == 1)
    assert np.array_equal(b.covers(centres), k <= 2)


def test_grid_masks():
    grid = CellGrid(P0, P1, N)
    m = grid.box_mask((0.5, 0.5, 0), (1.0, 1.5, 0.28))
    assert m.sum() == 2 * 4 and m[2:4, 2:6].all()
    grown = grid.dilate(m, 1)
    assert grown.sum() == 4 * 6 and grown[1:5, 1:7].all()
    pts = np.array([[0.3, 0.3, 0.1], [2.49, 1.99, 0.0], [0.25, 0.5, 0.2]])  # last on a corner
    assert np.argwhere(grid.cells_of(pts)).tolist() == [[1, 1], [1, 2], [9, 7]]
    with pytest.raises(ValueError, match="shape"):
        grid.check(np.ones((3, 3), bool))


def cell_indices(msh):
    n_cells = msh.topology.index_map(3).size_local
    mid = mesh.compute_midpoints(msh, 3, np.arange(n_cells, dtype=np.int32))
    return np.floor((mid - P0) / ((np.array(P1) - P0) / N)).astype(int)


def test_mesh_without_cells_is_exact():
    rng = np.random.default_rng(3)
    removed = rng.random(N) < 0.3
    msh = box_mesh_without_cells(P0, P1, N, removed)
    cell_volume = np.prod((np.array(P1) - P0) / N)
    vol = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=msh)))
    assert vol == pytest.approx((~removed).sum() * cell_volume, rel=1e-13)
    idx = cell_indices(msh)
    assert len(idx) == (~removed).sum()
    assert not removed[tuple(idx.T)].any(), "no cell of the mesh is a removed one"
    assert len({tuple(i) for i in idx}) == len(idx)
    # nodes: the grid vertices of the kept cells
    kept = np.argwhere(~removed)
    corners = (kept[:, None, :] + np.array(np.meshgrid(*[[0, 1]] * 3, indexing="ij")).reshape(3, -1).T)
    expected = np.unique(corners.reshape(-1, 3), axis=0)
    assert msh.geometry.x.shape[0] == len(expected)
    got = np.unique(np.round((msh.geometry.x - P0) / ((np.array(P1) - P0) / N)).astype(int), axis=0)
    assert np.array_equal(got, expected)


def test_mesh_without_cells_refuses_bad_masks():
    with pytest.raises(ValueError, match="shape"):
        box_mesh_without_cells(P0, P1, N, np.zeros((10, 8), bool))
    with pytest.raises(ValueError, match="every cell"):
        box_mesh_without_cells(P0, P1, N, np.ones(N, bool))


def test_the_nearest_cells_give_the_depth_over_every_cell_bit_for_bit():
    """Equal square cells: the depth from the cells a Chebyshev tree finds nearest is the
    minimum over every cell, to the last bit, on random zones and points, those on cell faces
    and corners included."""
    rng = np.random.default_rng(3)
    for _ in range(10):
        n = (int(rng.integers(5, 30)), int(rng.integers(5, 30)), 2)
        grid = CellGrid(P0, (n[0] * 0.0625, n[1] * 0.0625, 0.28), n)
        mask = rng.random(grid.shape) < rng.uniform(0.1, 0.6)
        mask[0, 0] = mask[-1, -1] = True
        zone = grid.zone(mask)
        assert zone._tree is not None
        x = rng.uniform(-0.5, 1.5, (5000, 3)) * np.array([n[0] * 0.0625, n[1] * 0.0625, 0.28])
        x[:2000, :2] = np.round(x[:2000, :2] / 0.03125) * 0.03125
        fast = zone.depth(x)
        zone._tree = None                   # every cell
        assert np.array_equal(fast, zone.depth(x))
