"""Graded tensor-product FE meshes around a box-shaped hole (the DE zone)."""
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from fenicsx_side.mesh import graded_axis, tensor_box_with_hole

# the paper-scale slab's DE box (cases/slab.py: 0.64 × 0.57 m on the 2.5 × 2 m slab) and bands
# of 3 cells of 2 sphere diameters (R = 11.2 mm)
H, LAYERS, RATIO, H_MAX = 0.0448, 3, 1.2, 0.15
X_HOLE, Y_HOLE = (0.9286, 1.5714), (0.7143, 1.2857)


def paper_axes():
    xs = graded_axis(0.0, 2.5, *X_HOLE, H, LAYERS, RATIO, H_MAX)
    ys = graded_axis(0.0, 2.0, *Y_HOLE, H, LAYERS, RATIO, H_MAX)
    return xs, ys, np.linspace(0.0, 0.28, 9)


@pytest.mark.parametrize("hole, length", [(X_HOLE, 2.5), (Y_HOLE, 2.0)])
def test_graded_axis_band_and_growth(hole, length):
    x = graded_axis(0.0, length, *hole, H, LAYERS, RATIO, H_MAX)
    cells = np.diff(x)
    assert x[0] == 0.0 and x[-1] == length
    assert np.all(cells > 0)
    lo, hi = (int(np.flatnonzero(x == b)[0]) for b in hole)  # the hole's faces are grid planes
    # the band: exactly LAYERS cells of H on each side of the hole (to the sums' round-off)
    assert cells[lo - LAYERS:lo] == pytest.approx(np.full(LAYERS, H), rel=1e-12)
    assert cells[hi:hi + LAYERS] == pytest.approx(np.full(LAYERS, H), rel=1e-12)
    # across the hole: equal cells of about H
    across = cells[lo:hi]
    assert np.ptp(across) < 1e-12 and abs(across[0] / H - 1) < 0.5 / len(across)
    growth = cells[1:] / cells[:-1]
    assert growth.max() <= RATIO * (1 + 1e-12) and growth.min() >= (1 - 1e-12) / RATIO
    assert cells.max() <= H_MAX * (1 + 1e-12)
    assert cells.max() > 2 * H  # it does coarsen away from the band


def test_graded_axis_fills_a_short_gap_and_refuses_what_cannot_fit():
    # 0.3 m below the band of 2 × 0.05 m: 2 cells of ratio <= 1.5 reach 0.1875 m, 3 reach 0.356:
    # 3 cells 0.05 (q, q², q³) with q + q² + q³ = 6
    x = graded_axis(0.0, 1.0, 0.4, 0.6, 0.05, 2, 1.5)
    assert x[0] == 0.0 and x[-1] == 1.0
    grown = np.diff(x)[2::-1]  # outward from the band
    q = grown[0] / 0.05
    assert q + q**2 + q**3 == pytest.approx(6.0, rel=1e-12)
    assert grown == pytest.approx(0.05 * q ** np.arange(1, 4), rel=1e-12)
    with pytest.raises(ValueError, match="do not fit"):
        graded_axis(0.0, 1.0, 0.1, 0.9, 0.05, 3)
    with pytest.raises(ValueError, match="cannot be filled"):
        graded_axis(0.0, 1.0, 0.11, 0.9, 0.05, 2, 1.2)  # 0.01 m left: < 0.05 / 1.2
    with pytest.raises(ValueError, match="ratio >= 1"):
        graded_axis(0.0, 1.0, 0.4, 0.6, 0.05, 2, 0.9)


def measure(msh, form):
    return fem.assemble_scalar(fem.form(form(msh)))


def test_graded_mesh_volume_and_hole_faces_are_exact():
    xs, ys, zs = paper_axes()
    lo, hi = (X_HOLE[0], Y_HOLE[0], 0.0), (X_HOLE[1], Y_HOLE[1], 0.28)
    msh = tensor_box_with_hole(xs, ys, zs, lo, hi)
    a, b, t = X_HOLE[1] - X_HOLE[0], Y_HOLE[1] - Y_HOLE[0], 0.28
    volume = measure(msh, lambda m: 1.0 * ufl.dx(domain=m))
    assert volume == pytest.approx(2.5 * 2.0 * t - a * b * t, rel=1e-13)
    # boundary = the slab's faces less the hole's top and bottom, plus the hole's 4 walls: only
    # if the walls are made of element faces
    area = measure(msh, lambda m: 1.0 * ufl.ds(domain=m))
    exact = 2 * (2.5 * 2.0 - a * b) + 2 * t * (2.5 + 2.0) + 2 * t * (a + b)
    assert area == pytest.approx(exact, rel=1e-13)
    x = msh.geometry.x
    assert not np.any(np.all((x > np.array(lo) + 1e-12) & (x < np.array(hi) - 1e-12), axis=1))
    n_cells = msh.topology.index_map(3).size_local
    assert n_cells == (len(xs) - 1) * (len(ys) - 1) * 8 - 14 * 13 * 8  # 14 × 13 cells removed


def test_graded_mesh_interpolates_linear_fields_exactly():
    """Q1 on the graded grid: a linear field's gradient is exact in every cell (the cells are
    boxes of all sizes, so a wrong vertex order would show here)."""
    xs, ys, zs = paper_axes()
    msh = tensor_box_with_hole(xs, ys, zs, (X_HOLE[0], Y_HOLE[0], 0.0),
                               (X_HOLE[1], Y_HOLE[1], 0.28))
    V = fem.FunctionSpace(msh, ("Lagrange", 1))
    u = fem.Function(V)
    u.interpolate(lambda p: 1.0 + 2.0 * p[0] - 3.0 * p[1] + 0.5 * p[2])
    g = ufl.grad(u) - ufl.as_vector((2.0, -3.0, 0.5))
    assert measure(msh, lambda m: ufl.inner(g, g) * ufl.dx(domain=m)) < 1e-24


def test_tensor_box_refuses_a_hole_off_the_grid():
    xs, ys, zs = np.linspace(0, 1, 5), np.linspace(0, 1, 5), np.linspace(0, 0.2, 2)
    with pytest.raises(ValueError, match=r"hole_lo\[0\] = 0.3 is not on a grid plane; "
                                         r"nearest: 0.25"):
        tensor_box_with_hole(xs, ys, zs, (0.3, 0.25, 0), (0.75, 0.75, 0.2))
    with pytest.raises(ValueError, match="increase strictly"):
        tensor_box_with_hole([0, 1, 0.5], ys, zs, (0, 0.25, 0), (1, 0.75, 0.2))
    with pytest.raises(ValueError, match="removes every cell"):
        tensor_box_with_hole(xs, ys, zs, (0, 0, 0), (1, 1, 0.2))
    msh = tensor_box_with_hole(xs, ys, zs, (0.25, 0.25, 0), (0.75, 0.75, 0.2))
    assert msh.topology.index_map(3).size_local == 16 - 4
    assert mesh.CellType.hexahedron == msh.topology.cell_type


def test_band_share_from_the_geometry():
    """cases.graded_band: the density measured on a paper-scale coupled model (the 0.6 m box
    and its 3-layer band together) predicts its band's own count (17,343 bridging spheres
    measured) to 0.5 %; the zone grown by zone_scale_for_share gives exactly the asked
    share."""
    from cases.graded_band import PAPER_COUPLED, band_figures, shell_area, zone_scale_for_share
    measured = band_figures(3, 0.0714285714285714 / 0.0224)
    assert measured.coupled == pytest.approx(PAPER_COUPLED["slab_spheres"], rel=1e-12)
    assert measured.band == pytest.approx(PAPER_COUPLED["bridging"], rel=5e-3)
    assert shell_area(1.0, 2.0, 0.5) == 2.0 * 3.0 - 2.0
    a, b, w = 0.6429, 0.5714, 0.1344
    k = zone_scale_for_share(a, b, w, 0.35)
    assert shell_area(k * a, k * b, w) / (k * k * a * b + shell_area(k * a, k * b, w)) == \
        pytest.approx(0.35, rel=1e-12)
