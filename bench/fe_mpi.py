"""FE partner distributed under MPI: seconds per step of the FE work a coupled step asks of it
(predict, gather u to rank 0, scatter a correction back), for a few mesh sizes.

Run as `mpirun -n N /usr/bin/python3 -m bench.fe_mpi [--cells 20x16x4 ...] [--steps 200]`;
rank 0 prints one JSON line per mesh.
"""
import argparse
import json
from time import perf_counter

import numpy as np
from mpi4py import MPI

from fenicsx_side.distributed import RankZeroModel
from fenicsx_side.mesh import box_mesh
from fenicsx_side.model import ElasticModel, face


def measure(cells, steps):
    comm = MPI.COMM_WORLD
    t0 = perf_counter()
    msh = box_mesh((0, 0, 0), (2.5, 2.0, 0.28), cells, comm=comm)
    model = ElasticModel(msh, 31e9, 0.2, 2400.0, [(face(0, 0.0), (2,)), (face(0, 2.5), (2,))])
    fe = RankZeroModel(model)
    if comm.rank != 0:
        fe.serve()
        return None
    build = perf_counter() - t0
    dt = 0.5 * fe.critical_dt()
    dofs = np.arange(0, fe.ndof, 7)  # a coupling touches a fraction of the dofs
    split = {"predict": 0.0, "gather": 0.0, "scatter": 0.0}
    for _ in range(steps):
        t1 = perf_counter()
        fe.predict(dt)
        t2 = perf_counter()
        u = fe.u
        t3 = perf_counter()
        fe.correct(dofs, 1e-12 * u[dofs], dt)
        t4 = perf_counter()
        split["predict"] += t2 - t1
        split["gather"] += t3 - t2
        split["scatter"] += t4 - t3
    fe.stop()
    return {"ranks": comm.size, "cells": list(cells), "nodes": fe.ndof // 3, "build_s": build,
            "ms_per_step": {k: 1e3 * v / steps for k, v in split.items()},
            "ms_per_step_total": 1e3 * sum(split.values()) / steps}


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--cells", nargs="+", default=["15x12x4", "40x32x8", "100x80x10"])
    p.add_argument("--steps", type=int, default=200)
    args = p.parse_args()
    for spec in args.cells:
        r = measure([int(c) for c in spec.split("x")], args.steps)
        if r is not None:
            print(json.dumps(r), flush=True)


if __name__ == "__main__":
    main()
