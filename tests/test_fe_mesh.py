"""FE meshes: box with a hole, gmsh files read through meshio."""
import meshio
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh

from fenicsx_side.mesh import box_mesh, box_mesh_with_hole, read_msh


def volume(msh):
    return fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=msh)))


@pytest.mark.parametrize("cell", ["hexahedron", "tetrahedron"])
def test_hole_removes_exactly_the_hole_cells(cell):
    p0, p1, n = (0, 0, 0), (2.5, 2.0, 0.28), (10, 8, 2)
    lo, hi = (1.0, 0.75, 0.0), (1.5, 1.25, 0.28)     # on grid planes, through the thickness
    msh = box_mesh_with_hole(p0, p1, n, lo, hi, cell)
    assert volume(msh) == pytest.approx(2.5 * 2.0 * 0.28 - 0.5 * 0.5 * 0.28, rel=1e-13)
    mid = mesh.compute_midpoints(msh, 3, np.arange(msh.topology.index_map(3).size_local,
                                                   dtype=np.int32))
    assert not np.any(np.all((mid > lo) & (mid < hi), axis=1))
    # the hole's corners are mesh nodes, on both faces of the slab
    for corner in [(1.0, 0.75, 0.0), (1.5, 1.25, 0.28), (1.0, 1.25, 0.14)]:
        assert np.min(np.linalg.norm(msh.geometry.x - corner, axis=1)) < 1e-14


def test_hole_off_the_grid_is_refused():
    with pytest.raises(ValueError, match=r"hole_lo\[0\] = 1.1 .*nearest planes: 1.0, 1.25"):
        box_mesh_with_hole((0, 0, 0), (2.5, 2, 0.28), (10, 8, 2), (1.1, 0.75, 0), (1.5, 1.25, 0.28))
    with pytest.raises(ValueError, match="removes every cell"):
        box_mesh_with_hole((0, 0, 0), (1, 1, 1), (2, 2, 2), (0, 0, 0), (1, 1, 1))


def test_bad_box_arguments():
    with pytest.raises(ValueError, match="cell must be one of"):
        box_mesh((0, 0, 0), (1, 1, 1), (2, 2, 2), "prism")
    with pytest.raises(ValueError, match="must exceed p0"):
        box_mesh((0, 0, 0), (1, 0, 1), (2, 2, 2))
    with pytest.raises(ValueError, match="positive integers"):
        box_mesh((0, 0, 0), (1, 1, 1), (2, 0, 2))


def structured_grid(n, h):
    """Nodes of an n[0] x n[1] x n[2] grid of step h and its hexahedra in VTK/gmsh order."""
    I, J, K = np.meshgrid(*[np.arange(m + 1) for m in n], indexing="ij")
    idx = I + (n[0] + 1) * (J + (n[1] + 1) * K)
    points = np.empty((idx.size, 3))
    points[idx.ravel()] = h * np.stack([I, J, K], axis=-1).reshape(-1, 3)
    i, j, k = (a.ravel() for a in np.meshgrid(*[np.arange(m) for m in n], indexing="ij"))
    corner = lambda a, b, c: idx[i + a, j + b, k + c]
    hexes = np.stack([corner(0, 0, 0), corner(1, 0, 0), corner(1, 1, 0), corner(0, 1, 0),
                      corner(0, 0, 1), corner(1, 0, 1), corner(1, 1, 1), corner(0, 1, 1)], axis=1)
    return points, hexes


def test_structured_grid_helper_is_right():
    points, hexes = structured_grid((2, 1, 1), 0.5)
    assert np.allclose(points[hexes[1]] - points[hexes[1][0]],
                       0.5 * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                                       [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]))


@pytest.mark.parametrize("kind", ["hexahedron", "tetra"])
def test_read_msh(tmp_path, kind):
    n, h = (3, 2, 2), 0.25
    points, hexes = structured_grid(n, h)
    if kind == "tetra":  # 6 tetrahedra around the diagonal 0-6 of each hexahedron
        loops = [(1, 2), (2, 3), (3, 7), (7, 4), (4, 5), (5, 1)]
        cells = np.concatenate([hexes[:, [0, a, b, 6]] for a, b in loops])
    else:
        cells = hexes
    # an unused node and a surface block, as gmsh files have: both must be ignored
    points = np.vstack([points, [9.0, 9.0, 9.0]])
    faces = hexes[:2, :3]
    path = tmp_path / "box.msh"
    meshio.write(path, meshio.Mesh(points, [(kind, cells), ("triangle", faces)]),
                 file_format="gmsh22", binary=False)
    msh = read_msh(path)
    assert msh.topology.index_map(3).size_local == len(cells)
    assert volume(msh) == pytest.approx(np.prod(n) * h ** 3, rel=1e-13)
    x = msh.geometry.x[msh.geometry.dofmap.array.reshape(len(cells), -1)]
    if kind == "hexahedron":  # dolfinx's tensor-product order: axes from vertex 0 to 1, 2, 4
        for v, axis in ((1, 0), (2, 1), (4, 2)):
            assert np.allclose(x[:, v] - x[:, 0], h * np.eye(3)[axis])


def test_read_msh_refuses_mixed_cells(tmp_path):
    points, hexes = structured_grid((1, 1, 1), 1.0)
    path = tmp_path / "mixed.msh"
    meshio.write(path, meshio.Mesh(points, [("hexahedron", hexes), ("tetra", hexes[:, :4])]),
                 file_format="gmsh22", binary=False)
    with pytest.raises(ValueError, match="exactly one of the types"):
        read_msh(path)
