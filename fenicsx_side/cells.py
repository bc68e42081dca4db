"""A structured hexahedral box mesh with any set of its grid cells removed (the FE part of a
coupled model whose DE zone is a union of grid cells)."""
import numpy as np
from dolfinx import mesh
from mpi4py import MPI


def box_mesh_without_cells(p0, p1, n, removed, comm=MPI.COMM_WORLD):
    """The hexahedral mesh of the box [p0, p1] with n = (nx, ny, nz) cells, less the cells
    (i, j, k) where removed[i, j, k] (a boolean array of shape n) is True."""
    p0, p1 = np.asarray(p0, float).reshape(3), np.asarray(p1, float).reshape(3)
    n = np.asarray(n, int).reshape(3)
    removed = np.asarray(removed, bool)
    if removed.shape != tuple(n):
        raise ValueError(f"removed cells: a mask of shape {tuple(n)} is needed, got "
                         f"{removed.shape}")
    if removed.all():
        raise ValueError("removed cells: every cell of the box would be removed")
    full = mesh.create_box(comm, [p0, p1], n.tolist(), cell_type=mesh.CellType.hexahedron)
    tdim = full.topology.dim
    n_cells = full.topology.index_map(tdim).size_local
    mid = mesh.compute_midpoints(full, tdim, np.arange(n_cells, dtype=np.int32))
    # a midpoint is half a cell from every grid plane: floor gives its cell without ambiguity
    index = np.floor((mid - p0) / ((p1 - p0) / n)).astype(int)
    keep = np.flatnonzero(~removed[tuple(index.T)]).astype(np.int32)
    return mesh.create_submesh(full, tdim, keep)[0]
