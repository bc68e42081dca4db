"""Run under `mpirun -n N`: the FE model distributed over N ranks and driven from rank 0
(RankZeroModel) against the same model built serially on rank 0. Prints one JSON line of
relative differences (rank 0)."""
import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from fenicsx_side.distributed import RankZeroModel  # noqa: E402
from fenicsx_side.mesh import box_mesh  # noqa: E402
from fenicsx_side.model import ElasticModel, face  # noqa: E402


def build(comm):
    msh = box_mesh((0, 0, 0), (1.0, 0.6, 0.3), (10, 6, 3), comm=comm)
    return ElasticModel(msh, 30e9, 0.2, 2400.0, [(face(0, 0.0), (0, 1, 2))])


def main():
    world = MPI.COMM_WORLD
    dist = RankZeroModel(build(world))
    if world.rank != 0:
        dist.serve()
        return
    serial = build(MPI.COMM_SELF)
    # the partitioned mesh numbers nodes differently: match them by coordinates
    key = lambda x: np.lexsort(np.round(x, 9).T[::-1])
    to_serial_node = np.empty(len(dist.nodes), int)
    to_serial_node[key(dist.nodes)] = key(serial.nodes)
    to_serial = (3 * to_serial_node[:, None] + np.arange(3)).ravel()
    rel = lambda a, b: float(np.abs(a - b).max() / np.abs(b).max())

    out = {"ranks": world.size,
           "nodes": float(np.abs(dist.nodes - serial.nodes[to_serial_node]).max()),
           "mass": rel(dist.mass, serial.mass[to_serial]),
           "fixed_mismatch": int((dist.fixed != serial.fixed[to_serial]).sum()),
           "critical_dt": rel(dist.critical_dt(), serial.critical_dt()),
           "critical_dt_bound": rel(dist.critical_dt_bound(), serial.critical_dt_bound())}
    points = np.random.default_rng(0).uniform((0.05, 0.05, 0.05), (0.95, 0.55, 0.25), (200, 3))
    (kd, hd), (ks, hs) = dist.point_operators(points), serial.point_operators(points)
    out["k"] = rel(kd.toarray(), ks[:, to_serial].toarray())
    out["h"] = rel(hd.toarray(), hs[:, to_serial].toarray())

    # free vibration from a bump, with corrections at the dofs k touches every 10 steps
    bump = lambda x: 1e-4 * np.exp(-((x[:, 0] - 0.6) ** 2 + (x[:, 1] - 0.3) ** 2) / 0.01)
    dt = 0.5 * serial.critical_dt()
    u0 = np.zeros(serial.ndof)
    u0[2::3] = bump(serial.nodes)
    u0[serial.fixed] = 0
    serial.correct(np.arange(serial.ndof), u0, dt)
    dist.correct(np.arange(dist.ndof), u0[to_serial], dt)
    dofs = np.unique(kd.indices)
    for step in range(300):
        dist.predict(dt)
        serial.predict(dt)
        if step % 10 == 0:
            du = 1e-3 * dist.u[dofs]
            dist.correct(dofs, du, dt)
            serial.correct(to_serial[dofs], du, dt)
    out["u"] = rel(dist.u, serial.u[to_serial])
    out["v"] = rel(dist.v, serial.v[to_serial])
    out["kinetic_energy"] = rel(dist.kinetic_energy(), serial.kinetic_energy())
    out["strain_energy"] = rel(dist.strain_energy(), serial.strain_energy())
    sd, ss = dist.stress(), serial.stress()
    out["cells"] = [len(dist.cell_nodes), len(serial.cell_nodes)]
    out["von_mises_max"] = rel(sd.von_mises.max(), ss.von_mises.max())
    dist.stop()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
