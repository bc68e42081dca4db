"""Run by pvpython (tests/test_paraview.py): what ParaView's own readers see in a run's
spheres.pvd and fe.xdmf, as one JSON line: per reader, the times, and at the last time the
dataset type, point and cell counts, the point and cell arrays (components) and the range of
the displacement magnitude."""
import json
import sys

from paraview.simple import PVDReader, XDMFReader, Xdmf3ReaderS, Xdmf3ReaderT


def seen(reader):
    times = list(reader.TimestepValues)
    reader.UpdatePipeline(times[-1])
    info = reader.GetDataInformation()
    points = reader.GetPointDataInformation()
    return {"times": times, "type": info.GetDataSetTypeAsString(),
            "points": info.GetNumberOfPoints(), "cells": info.GetNumberOfCells(),
            "point_arrays": {a.Name: a.GetNumberOfComponents() for a in reader.PointData},
            "cell_arrays": {a.Name: a.GetNumberOfComponents() for a in reader.CellData},
            "displacement_magnitude": list(points.GetArray("displacement").GetRange(-1))}


run = sys.argv[1]
print(json.dumps({"PVDReader": seen(PVDReader(FileName=f"{run}/spheres.pvd")),
                  "Xdmf3ReaderS": seen(Xdmf3ReaderS(FileName=f"{run}/fe.xdmf")),
                  "Xdmf3ReaderT": seen(Xdmf3ReaderT(FileName=f"{run}/fe.xdmf")),
                  "XDMFReader": seen(XDMFReader(FileNames=[f"{run}/fe.xdmf"]))}))
