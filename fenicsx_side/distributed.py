"""Driving a distributed ElasticModel from rank 0.

Under `mpirun -n N` the FE model is partitioned over the ranks (dolfinx/PETSc), while the
partner that talks to it (the coupling, YADE) lives on rank 0 only. `RankZeroModel` gives rank 0
the serial ElasticModel interface in the global dof numbering: every method call on rank 0 is
broadcast to the other ranks, which run `serve()` and take part in the same collective
operation. State vectors are gathered to rank 0 whole (the FE costs little next to YADE here,
so simplicity wins over sending only the coupled dofs), and corrections are scattered back.
"""
import atexit

import numpy as np
from mpi4py import MPI

from fenicsx_side.model import CellStress

_STOP = "stop"


class RankZeroModel:
    """Rank 0's view of a distributed ElasticModel `model` (construct on every rank).

    Global arrays, gathered once: nodes, mass, fixed, cell_nodes (global node indices), and
    ndof. Collective calls: predict, correct, u, v, kinetic_energy, strain_energy,
    critical_dt, critical_dt_bound, point_operators, check_covered, stress; ranks other than
    0 call serve() instead.
    """

    def __init__(self, model):
        self.model = model
        self.comm = model.comm
        self.rank = self.comm.rank
        self._counts = np.array(self.comm.allgather(model.ndof))
        first = np.array(self.comm.allgather(int(model.global_dofs[0]) if model.ndof else 0))
        if not np.array_equal(first[self._counts > 0], _offsets(self._counts)[self._counts > 0]):
            # the gathers below put each rank's owned block end to end
            raise RuntimeError("owned dofs are not contiguous blocks in rank order")
        self.ndof = model.ndof_global
        self.nodes = self._gather(model.nodes.ravel())
        self.mass = self._gather(model.mass)
        self.fixed = self._gather(model.fixed.astype(float))
        self.cell_nodes = self._gather_rows(model._global_node[model.cell_nodes])
        if self.rank == 0:
            self.nodes = self.nodes.reshape(-1, 3)
            self.fixed = self.fixed.astype(bool)
        self._correction = np.zeros(self.ndof) if self.rank == 0 else None
        self._stopped = False
        if self.rank == 0:
            atexit.register(self.stop)  # however rank 0 ends, the others leave serve()

    carries_damage = False      # fenicsx_side.damaged runs on one rank

    @property
    def distributed(self):
        return self.comm.size > 1

    # --- what rank 0 calls (each is collective) ----------------------------------------------
    def predict(self, dt):
        self._call("predict", dt)

    def correct(self, dofs, du, dt):
        """Add du to the global dofs `dofs` (unique) of u, du/dt to v."""
        self._correction[:] = 0.0
        self._correction[dofs] = du
        self._call("correct", dt)

    @property
    def u(self):
        """The global displacement (a gathered copy)."""
        return self._call("gather_state", "u")

    @property
    def v(self):
        return self._call("gather_state", "v")

    def kinetic_energy(self):
        return self._call("kinetic_energy")

    def strain_energy(self):
        return self._call("strain_energy")

    def critical_dt(self):
        return self._call("critical_dt")

    def critical_dt_bound(self):
        return self._call("critical_dt_bound")

    def point_operators(self, points):
        return self._call("point_operators", np.asarray(points, float))

    def stress(self):
        return self._call("stress")

    def check_covered(self, points):
        self._call("check_covered", np.asarray(points, float))

    def stop(self):
        """Release the other ranks from serve() (once)."""
        if not self._stopped:
            self._stopped = True
            self.comm.bcast((_STOP, ()), root=0)

    # --- the other ranks ---------------------------------------------------------------------
    def serve(self):
        """Ranks > 0: take part in rank 0's calls until it stops."""
        while True:
            name, args = self.comm.bcast(None, root=0)
            if name == _STOP:
                return
            getattr(self, f"_{name}")(*args)

    # --- the collective implementations ------------------------------------------------------
    def _call(self, name, *args):
        if self.rank != 0:
            raise RuntimeError("RankZeroModel is driven from rank 0; other ranks call serve()")
        self.comm.bcast((name, args), root=0)
        return getattr(self, f"_{name}")(*args)

    def _predict(self, dt):
        self.model.predict(dt)

    def _correct(self, dt):
        local = np.empty(self.model.ndof)
        self.comm.Scatterv([self._correction, self._counts, _offsets(self._counts), MPI.DOUBLE]
                           if self.rank == 0 else None, local, root=0)
        touched = np.flatnonzero(local)
        self.model.correct(touched, local[touched], dt)

    def _gather(self, local):
        """Rank 0: the ranks' arrays of doubles end to end, in rank order."""
        local = np.ascontiguousarray(local, float)
        counts = np.array(self.comm.allgather(local.size))
        out = np.empty(counts.sum()) if self.rank == 0 else None
        self.comm.Gatherv(local, [out, counts, _offsets(counts), MPI.DOUBLE]
                          if self.rank == 0 else None, root=0)
        return out

    def _gather_rows(self, rows):
        parts = self.comm.gather(rows, root=0)
        return np.concatenate(parts) if self.rank == 0 else None

    def _gather_state(self, name):
        return self._gather(getattr(self.model, name))

    def _kinetic_energy(self):
        return self.model.kinetic_energy()

    def _strain_energy(self):
        return self.model.strain_energy()

    def _critical_dt(self):
        return self.model.critical_dt()

    def _critical_dt_bound(self):
        return self.model.critical_dt_bound()

    def _point_operators(self, points):
        return self.model.point_operators(points)

    def _check_covered(self, points):
        try:
            self.model.check_covered(points)
        except ValueError:      # every rank finds it; rank 0 reports it, the others go on
            if self.rank == 0:
                raise

    def _stress(self):
        s = self.model.stress()
        parts = [self._gather_rows(a) for a in (s.tensor, s.von_mises, s.max_principal)]
        return CellStress(*parts) if self.rank == 0 else None


def on_rank_zero(model):
    """`model` as rank 0 drives it: itself in serial, else a RankZeroModel (collective)."""
    return model if model.comm.size == 1 else RankZeroModel(model)


def serve(model):
    """Ranks > 0: take part in everything rank 0 asks of the distributed `model` until it
    stops (`model` built collectively with rank 0's own)."""
    RankZeroModel(model).serve()


def _offsets(counts):
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int)
