"""XDMF time series of the FE model: displacement, velocity, stress (ParaView, meshio).

One temporal collection holds every field of a step (dolfinx's own XDMFFile writes one
collection per function, which meshio's TimeSeriesReader cannot read, and meshio's writer puts
its .h5 in the working directory). The .h5 and .xdmf files are written under temporary names
and renamed on close, .h5 first: a reader never sees a half-written series.
"""
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
from dolfinx import cpp, mesh

_TOPOLOGY = {4: ("Tetrahedron", mesh.CellType.tetrahedron),
             8: ("Hexahedron", mesh.CellType.hexahedron)}
_ATTRIBUTE_TYPE = {1: "Scalar", 3: "Vector", 9: "Tensor"}
_MESH_XPOINTER = ("xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]"
                  "/*[self::Topology or self::Geometry])")


class XdmfSeries:
    """Time series of `model` (an ElasticModel) in `path` (.xdmf) and its sibling .h5.

    Point fields: displacement, velocity (the half-step velocity v(t - dt/2)); cell fields:
    stress (cell-average tensor, 9 components), von_mises, max_principal. write() takes extra
    fields as point_data / cell_data dicts of arrays with one row per node / cell.
    """

    def __init__(self, path, model):
        self.path = Path(path)
        if self.path.suffix != ".xdmf":
            raise ValueError(f"XDMF series path must end in .xdmf, got {str(self.path)!r}")
        self.model = model
        self.h5_path = self.path.with_suffix(".h5")
        self._h5_part = self.h5_path.with_name(f".{self.h5_path.name}.part")
        self._h5 = h5py.File(self._h5_part, "w")
        self._steps = 0
        self._xml = ET.Element("Xdmf", {"Version": "3.0",
                                        "xmlns:xi": "http://www.w3.org/2001/XInclude"})
        domain = ET.SubElement(self._xml, "Domain")
        grid = ET.SubElement(domain, "Grid", Name="mesh", GridType="Uniform")
        nv = model.cell_nodes.shape[1]
        name, cell_type = _TOPOLOGY[nv]
        # dolfinx numbers hexahedron vertices in tensor-product order; XDMF uses VTK's
        cells = model.cell_nodes[:, np.argsort(cpp.io.perm_vtk(cell_type, nv))]
        topology = ET.SubElement(grid, "Topology", TopologyType=name,
                                 NumberOfElements=str(len(cells)), NodesPerElement=str(nv))
        self._data_item(topology, "mesh/topology", cells.astype(np.int64))
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
        self._data_item(geometry, "mesh/geometry", model.nodes)
        self._series = ET.SubElement(domain, "Grid", Name="fe", GridType="Collection",
                                     CollectionType="Temporal")

    def write(self, t, point_data=None, cell_data=None):
        """Append the model's current state as time t."""
        m = self.model
        stress = m.stress()
        points = {"displacement": m.u.reshape(-1, 3), "velocity": m.v.reshape(-1, 3),
                  **(point_data or {})}
        cells = {"stress": stress.tensor.reshape(-1, 9), "von_mises": stress.von_mises,
                 "max_principal": stress.max_principal, **(cell_data or {})}
        fields = [(center, name, _rows(name, values, rows))
                  for center, data, rows in (("Node", points, len(m.nodes)),
                                             ("Cell", cells, len(m.cell_nodes)))
                  for name, values in data.items()]
        grid = ET.SubElement(self._series, "Grid", Name=f"step{self._steps}", GridType="Uniform")
        ET.SubElement(grid, "xi:include", xpointer=_MESH_XPOINTER)
        ET.SubElement(grid, "Time", Value=repr(float(t)))
        for center, name, values in fields:
            attribute = ET.SubElement(grid, "Attribute", Name=name, Center=center,
                                      AttributeType=_ATTRIBUTE_TYPE[values.shape[1]])
            self._data_item(attribute, f"step{self._steps}/{name}", values)
        self._h5.flush()
        self._steps += 1

    def close(self):
        """Finish both files and move them to their final names (also after an error in a
        `with` block: the steps written so far are complete)."""
        if self._h5 is None:
            return
        self._h5.close()
        self._h5 = None
        os.replace(self._h5_part, self.h5_path)
        xml_part = self.path.with_name(f".{self.path.name}.part")
        ET.indent(self._xml)
        ET.ElementTree(self._xml).write(xml_part, xml_declaration=True, encoding="utf-8")
        os.replace(xml_part, self.path)

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def _data_item(self, parent, name, values):
        self._h5.create_dataset(name, data=values)
        is_int = np.issubdtype(values.dtype, np.integer)
        item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(map(str, values.shape)),
                             DataType="Int" if is_int else "Float",
                             Precision=str(values.dtype.itemsize), Format="HDF")
        item.text = f"{self.h5_path.name}:/{name}"


def _rows(name, values, rows):
    """values as a float array of `rows` rows of 1, 3 or 9 components."""
    values = np.asarray(values, float).reshape(rows, -1)
    if values.shape[1] not in _ATTRIBUTE_TYPE:
        raise ValueError(f"field {name!r}: {values.shape[1]} components per row; "
                         f"need one of {tuple(_ATTRIBUTE_TYPE)}")
    return values
