"""XDMF time series of the FE model: displacement, velocity, stress (ParaView, meshio).

One temporal collection holds every field of a step (dolfinx's own XDMFFile writes one
collection per function, which meshio's TimeSeriesReader cannot read). The mesh and each frame
go to their own HDF5 file in a folder beside the .xdmf index (`fe.xdmf`, `fe/mesh.h5`,
`fe/step000000.h5`, ...); every file is written under a temporary name and renamed, the index
last, after each frame. A reader, or a run killed at any moment, only ever sees complete
frames, and a resumed run carries on from a given frame.

The index has one grid, the temporal collection, and every frame names the mesh file itself:
a standalone mesh grid beside the collection (dolfinx's layout, reached by xi:include) is
read by ParaView's XDMF (version 2) reader as a second block on top of the series, which
doubles the points it shows.
"""
import copy
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
from dolfinx import cpp, mesh

from common.files import atomic

_TOPOLOGY = {4: ("Tetrahedron", mesh.CellType.tetrahedron),
             8: ("Hexahedron", mesh.CellType.hexahedron)}
_ATTRIBUTE_TYPE = {1: "Scalar", 3: "Vector", 9: "Tensor"}


class XdmfSeries:
    """Time series of `model` (an ElasticModel) in `path` (.xdmf) and the folder beside it.

    Point fields: displacement, velocity (the half-step velocity v(t - dt/2)); cell fields:
    stress (cell-average tensor, 9 components), von_mises, max_principal. write() takes extra
    fields as point_data / cell_data dicts of arrays with one row per node / cell.
    `frames`: keep that many frames of an existing series (a resumed run) and write after them.
    """

    def __init__(self, path, model, frames=0):
        self.path = Path(path)
        if self.path.suffix != ".xdmf":
            raise ValueError(f"XDMF series path must end in .xdmf, got {str(self.path)!r}")
        self.model = model
        self.folder = self.path.with_suffix("")
        self._xml = ET.Element("Xdmf", Version="3.0")
        domain = ET.SubElement(self._xml, "Domain")
        nv = model.cell_nodes.shape[1]
        name, cell_type = _TOPOLOGY[nv]
        # dolfinx numbers hexahedron vertices in tensor-product order; XDMF uses VTK's
        cells = model.cell_nodes[:, np.argsort(cpp.io.perm_vtk(cell_type, nv))]
        topology = ET.Element("Topology", TopologyType=name, NumberOfElements=str(len(cells)),
                              NodesPerElement=str(nv))
        geometry = ET.Element("Geometry", GeometryType="XYZ")
        # written with the first frame: a series that gets none (a grown zone that ends
        # before the next output) leaves no file
        self._mesh_items = {"topology": (topology, cells.astype(np.int64)),
                            "geometry": (geometry, model.nodes)}
        self._mesh = (topology, geometry)     # copied into every frame
        self._series = ET.SubElement(domain, "Grid", Name="fe", GridType="Collection",
                                     CollectionType="Temporal")
        self._steps = 0
        if frames:
            self._keep(frames)

    def write(self, t, point_data=None, cell_data=None):
        """Append the model's current state as time t."""
        m = self.model
        stress = m.stress()
        points = {"displacement": m.u.reshape(-1, 3), "velocity": m.v.reshape(-1, 3),
                  **(point_data or {})}
        cells = {"stress": stress.tensor.reshape(-1, 9), "von_mises": stress.von_mises,
                 "max_principal": stress.max_principal,
                 **({"damage": m.damage} if m.carries_damage else {}), **(cell_data or {})}
        fields = {name: (center, _rows(name, values, rows))
                  for center, data, rows in (("Node", points, len(m.nodes)),
                                             ("Cell", cells, len(m.cell_nodes)))
                  for name, values in data.items()}
        self._frame(t, fields)
        self._write_index()

    def close(self):
        """Nothing left to finish (the index is complete after every frame); kept so that a
        series can be used as a context manager."""

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def _frame(self, t, fields, written=False):
        if self._mesh_items is not None:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._write_h5("mesh.h5", self._mesh_items)
            self._mesh_items = None
        grid = ET.SubElement(self._series, "Grid", Name=f"step{self._steps}", GridType="Uniform")
        grid.extend(copy.deepcopy(self._mesh))
        ET.SubElement(grid, "Time", Value=repr(float(t)))
        items = {}
        for name, (center, values) in fields.items():
            attribute = ET.SubElement(grid, "Attribute", Name=name, Center=center,
                                      AttributeType=_ATTRIBUTE_TYPE[values.shape[1]])
            items[name] = (attribute, values)
        self._write_h5(f"step{self._steps:06d}.h5", items, {"time": float(t)}, written)
        self._steps += 1

    def _keep(self, frames):
        """Index the first `frames` frames already on disk (their times are in the files)."""
        for k in range(frames):
            path = self.folder / f"step{k:06d}.h5"
            if not path.is_file():
                raise ValueError(f"cannot resume the FE series: {path} is missing")
            with h5py.File(path, "r") as f:
                t = float(f.attrs["time"])
                fields = {name: (f[name].attrs["center"], f[name][()]) for name in f}
            self._frame(t, fields, written=True)

    def _write_h5(self, file_name, items, attrs=None, written=False):
        """DataItems under each parent for `items` {name: (parent, values)}, the values (and
        the file attributes `attrs`) in folder/file_name, unless already written there."""
        path = self.folder / file_name
        if not written:
            with atomic(path) as part, h5py.File(part, "w") as f:
                f.attrs.update(attrs or {})
                for name, (parent, values) in items.items():
                    f.create_dataset(name, data=values)
                    f[name].attrs["center"] = parent.get("Center", "")
        for name, (parent, values) in items.items():
            item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, values.shape)),
                                 DataType="Int" if np.issubdtype(values.dtype, np.integer)
                                 else "Float", Precision=str(values.dtype.itemsize),
                                 Format="HDF")
            item.text = f"{self.folder.name}/{file_name}:/{name}"

    def _write_index(self):
        ET.indent(self._xml)
        with atomic(self.path) as part:
            ET.ElementTree(self._xml).write(part, xml_declaration=True, encoding="utf-8")


def _rows(name, values, rows):
    """values as a float array of `rows` rows of 1, 3 or 9 components."""
    values = np.asarray(values, float).reshape(rows, -1)
    if values.shape[1] not in _ATTRIBUTE_TYPE:
        raise ValueError(f"field {name!r}: {values.shape[1]} components per row; "
                         f"need one of {tuple(_ATTRIBUTE_TYPE)}")
    return values
