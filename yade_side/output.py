"""Sphere time series for ParaView: one .vtu per frame (points at the current centres, with
radius, displacement, rotation, velocity, damage…) and a .pvd index of the frames.

Each file is written under a temporary name and renamed, the index last: ParaView and meshio
never see a half-written frame. Display with the "Point Gaussian" representation scaled by
`radius`, or the Glyph filter (sphere, scale by radius).
"""
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from common.files import atomic


class SphereSeries:
    def __init__(self, path, frames=0):
        """`frames`: keep that many frames of an existing series (a resumed run)."""
        self.path = Path(path)
        if self.path.suffix != ".pvd":
            raise ValueError(f"sphere series path must end in .pvd, got {str(self.path)!r}")
        self.frames_dir = self.path.with_suffix("")
        self.frames_dir.mkdir(parents=True, exist_ok=True)
        self.frames = []  # (time, relative file name)
        if frames:
            kept = _index(self.path)[:frames] if self.path.is_file() else []
            if len(kept) < frames:
                raise ValueError(f"cannot resume the sphere series {self.path}: it has "
                                 f"{len(kept)} frames, {frames} expected")
            self.frames = kept

    def write(self, t, centres, radius, **fields):
        """Append a frame: centres (n, 3), radius (n,), fields of n rows (scalars or vectors)."""
        n = len(centres)
        for name, values in fields.items():
            if len(values) != n:
                raise ValueError(f"sphere field {name!r} has {len(values)} rows for {n} spheres")
        name = f"{self.frames_dir.name}/frame_{len(self.frames):06d}.vtu"
        point_data = {"radius": np.asarray(radius, float)}
        point_data.update({k: np.asarray(v, float) for k, v in fields.items()})
        mesh = meshio.Mesh(np.asarray(centres, float), [("vertex", np.arange(n)[:, None])],
                           point_data=point_data)
        with atomic(self.path.parent / name) as part:
            meshio.write(part, mesh, file_format="vtu")
        self.frames.append((float(t), name))
        self._write_index()

    def _write_index(self):
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for t, name in self.frames:
            ET.SubElement(coll, "DataSet", timestep=repr(t), part="0", file=name)
        with atomic(self.path) as part:
            ET.ElementTree(root).write(part, xml_declaration=True, encoding="utf-8")


def read_series(path):
    """[(time, meshio.Mesh)] of a .pvd written by SphereSeries (for tests and post-processing)."""
    path = Path(path)
    return [(t, meshio.read(path.parent / name)) for t, name in _index(path)]


def _index(path):
    """[(time, file name relative to the index)] of a .pvd."""
    return [(float(d.get("timestep")), d.get("file"))
            for d in ET.parse(path).getroot().iter("DataSet")]
