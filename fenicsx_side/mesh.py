"""Meshes for the FE partner: structured boxes, boxes with a box-shaped hole, gmsh files."""
import numpy as np
import ufl
from dolfinx import cpp, mesh
from mpi4py import MPI

CELL_TYPES = {"hexahedron": mesh.CellType.hexahedron, "tetrahedron": mesh.CellType.tetrahedron}
# meshio's names of the linear 3D cells that read_msh accepts
_MESHIO_CELLS = {"tetra": "tetrahedron", "hexahedron": "hexahedron"}


def box_mesh(p0, p1, n, cell="hexahedron", comm=MPI.COMM_WORLD):
    """Structured mesh of the box [p0, p1] with n = (nx, ny, nz) divisions.

    Tetrahedra split each hexahedron of the grid into 6, so in both cases every grid plane
    p0 + (p1 - p0) i / n is made of element faces.
    """
    p0, p1, n = _box_arguments(p0, p1, n)
    if cell not in CELL_TYPES:
        raise ValueError(f"cell must be one of {tuple(CELL_TYPES)}, got {cell!r}")
    return mesh.create_box(comm, [p0, p1], n.tolist(), cell_type=CELL_TYPES[cell])


def box_mesh_with_hole(p0, p1, n, hole_lo, hole_hi, cell="hexahedron", comm=MPI.COMM_WORLD,
                       tol=1e-9):
    """box_mesh(p0, p1, n) without the cells inside the box [hole_lo, hole_hi].

    The hole's faces must lie on grid planes (within tol × element size) so that they are made
    of element faces. A hole through the whole thickness takes hole_lo[2] = p0[2] and
    hole_hi[2] = p1[2].
    """
    p0, p1, n = _box_arguments(p0, p1, n)
    lo, hi = (np.asarray(b, float).reshape(3) for b in (hole_lo, hole_hi))
    size = (p1 - p0) / n
    for name, bound in (("hole_lo", lo), ("hole_hi", hi)):
        i = (bound - p0) / size
        for axis in range(3):
            if not (-tol <= i[axis] <= n[axis] + tol and abs(i[axis] - round(i[axis])) <= tol):
                below = p0[axis] + size[axis] * np.clip(np.floor(i[axis]), 0, n[axis])
                above = p0[axis] + size[axis] * np.clip(np.ceil(i[axis]), 0, n[axis])
                raise ValueError(f"{name}[{axis}] = {bound[axis]!r} is not on a grid plane of "
                                 f"the box; nearest planes: {below!r}, {above!r}")
    if not np.all(hi > lo):
        raise ValueError(f"hole_hi {hi.tolist()} must exceed hole_lo {lo.tolist()} on every axis")
    full = box_mesh(p0, p1, n, cell, comm)
    tdim = full.topology.dim
    n_cells = full.topology.index_map(tdim).size_local
    mid = mesh.compute_midpoints(full, tdim, np.arange(n_cells, dtype=np.int32))
    # cell midpoints are never on a grid plane, so a strict test separates inside from outside
    keep = np.flatnonzero(~np.all((mid > lo) & (mid < hi), axis=1)).astype(np.int32)
    if keep.size == 0:
        raise ValueError(f"the hole [{lo.tolist()}, {hi.tolist()}] removes every cell of the box")
    return mesh.create_submesh(full, tdim, keep)[0]


def read_msh(path, comm=MPI.COMM_WORLD):
    """Read a gmsh .msh file of linear tetrahedra or hexahedra (not both) with meshio.

    Lower-dimensional cells (surfaces, lines, points) are ignored; so are nodes that no 3D cell
    uses. The mesh is built on rank 0 and distributed by dolfinx.
    """
    data = _read_meshio(path)
    kinds = {block.type for block in data.cells if block.dim == 3}
    accepted = kinds & set(_MESHIO_CELLS)
    if len(accepted) != 1 or kinds - accepted:
        raise ValueError(f"{path}: need 3D cells of exactly one of the types "
                         f"{tuple(_MESHIO_CELLS)}, found {sorted(kinds) or 'none'}")
    kind = accepted.pop()
    cells = np.concatenate([b.data for b in data.cells if b.type == kind]).astype(np.int64)
    used, inverse = np.unique(cells, return_inverse=True)
    cells = inverse.reshape(cells.shape)
    points = np.asarray(data.points, float)[used]
    if points.shape[1] != 3:
        raise ValueError(f"{path}: expected 3D points, got shape {points.shape}")
    cell_type = CELL_TYPES[_MESHIO_CELLS[kind]]
    # meshio keeps gmsh's (= VTK's for linear cells) local node order; dolfinx has its own
    cells = cells[:, cpp.io.perm_gmsh(cell_type, cells.shape[1])]
    if comm.rank != 0:
        cells, points = np.empty((0, cells.shape[1]), np.int64), np.empty((0, 3))
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", _MESHIO_CELLS[kind], 1))
    return mesh.create_mesh(comm, cells, points, domain)


def _read_meshio(path):
    """meshio's mesh of a file; ValueError naming the file when it is empty or unreadable
    (meshio itself fails with "need at least one array to concatenate" or exits)."""
    import contextlib
    import io
    import os
    import meshio
    if os.path.getsize(path) == 0:
        raise ValueError(f"mesh file {path} is empty")
    said = io.StringIO()               # meshio prints why it gives up, then exits
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            return meshio.read(path)
    except (Exception, SystemExit) as e:
        why = " ".join(said.getvalue().split()) if isinstance(e, SystemExit) else \
            f"{type(e).__name__}: {e}"
        raise ValueError(f"mesh file {path}: meshio cannot read it as a mesh ({why})") from None


def _box_arguments(p0, p1, n):
    p0, p1 = np.asarray(p0, float).reshape(3), np.asarray(p1, float).reshape(3)
    n = np.asarray(n).reshape(3)
    if not np.all(p1 > p0):
        raise ValueError(f"box corner p1 {p1.tolist()} must exceed p0 {p0.tolist()} on every axis")
    if not (np.issubdtype(n.dtype, np.integer) and np.all(n > 0)):
        raise ValueError(f"divisions n must be positive integers, got {n.tolist()}")
    return p0, p1, n
