"""A YADE scene run on MPI ranks with YADE's own yade.mpy: rank 0 builds the scene and drives
the run, the other ranks (workers) own its bodies and step them.

Rank 0 gives each body to a worker and the first step splits the scene (mpy sends it to the
workers). Rank 0 keeps inert copies of the bodies (their masses and radii); once the scene is
split, `BodySet` reads and writes and `LinkDamage`'s walks go to the owners through
`remote()`: every call of rank 0 is sent to the workers, which run `serve()` and take part.

What yade.mpy needs to carry CPM links across the subdomains (each found by a run that gave a
wrong answer without it, docs/mpi.md):
1. the collider labelled `collider` (mpy's parallel collision reads that name), or links across
   the boundary are never made;
2. the cohesive links made by the first step after the split: links made before are not
   carried as cohesive;
3. an absolute Verlet distance, and the body-less rank 0's NewtonIntegrator.maxVelocitySq held
   at the value mpy sets after a parallel collision, or rank 0 asks for a collision detection
   at every step (twice the cost);
4. bounds that keep covering linked pairs, so that a link's two spheres stay in each other's
   subdomain: the spheres' bounds keep the link-making enlargement (1.5);
5. states written between steps sent to the ranks that mirror those bodies, and a new parallel
   collision (`put`).
A link belongs to the rank that owns its first body (id1): each is counted once.
"""
import atexit
from time import perf_counter, sleep

import numpy as np

from yade_side import import_yade

_STOP = "stop"
_CALL_TAG = 7001
_SPIN, _NAP = 0.01, 0.001      # s: a worker waits this long for rank 0's next call, then naps
_SCENE = None          # rank 0's RankZeroScene once the scene is split, else None


def remote():
    """The split scene rank 0 drives (RankZeroScene), or None: bodies are in this process."""
    return _SCENE


def elastic_energy():
    """The CPM links' elastic energy (Law2_ScGeom_CpmPhys_Cpm.elasticEnergy()) of the scene,
    in this process or over the ranks; 0 without the law."""
    if _SCENE is not None:
        return _SCENE.elastic_energy()
    from yade_side.scene import cpm_law
    law = cpm_law()
    return law.elasticEnergy() if law is not None else 0.0


def _mpy():
    import __main__
    import sys
    import_yade()
    __main__.sys = sys                      # mpy's PyRunners name it in the namespace they run in
    from yade import mpy                    # joins the ranks on import
    mpy.VERBOSE_OUTPUT = mpy.COLOR_OUTPUT = mpy.YADE_TIMING = False
    mpy.ERASE_REMOTE_MASTER = False         # rank 0 keeps its copies (masses, radii)
    mpy.REALLOCATE_FREQUENCY = 0            # bodies stay with their owner
    return mpy


def owners(x, workers):
    """Owner rank (1 … workers) of bodies at abscissae `x`: slices along x of equal count."""
    order = np.argsort(x, kind="stable")
    owner = np.empty(len(x), int)
    owner[order] = 1 + (np.arange(len(x)) * workers) // len(x)
    return owner


class RankZeroScene:
    """Rank 0's handle on the scene its workers own. Collective calls: split, step, states,
    put, links, elastic_energy; the workers call serve() instead, which rank 0 ends by
    release_workers_at_exit()."""

    def __init__(self, comm):
        self.comm = comm
        self.rank = comm.rank
        self._own = np.empty(0, int)

    # --- what rank 0 calls (each is collective) ----------------------------------------------
    def split(self, owner, radius):
        """Give body i to rank owner[i] and run the first step, which splits the scene and
        makes the cohesive links; radius: the smallest sphere radius (the Verlet distance)."""
        O = import_yade().Omega()
        for b, rank in zip(O.bodies, owner):
            b.subdomain = int(rank)
        _engines_for_mpy(O, 0.5 * radius)
        global _SCENE
        self._call("split")
        _SCENE = self

    def step(self, n=1):
        self._call("step", n)

    def states(self, ids):
        """(len(ids), 13) state values of the bodies `ids` (bulk.BodySet's layout)."""
        return self._call("states", np.asarray(ids, int))

    def put(self, ids, values):
        self._call("put", np.asarray(ids, int), np.asarray(values, float).reshape(-1, 13))

    def links(self):
        """(pairs (n, 2), omega (n,)) of the scene's cohesive interactions, each once."""
        return self._call("links")

    def elastic_energy(self):
        """Law2_ScGeom_CpmPhys_Cpm.elasticEnergy() of the whole scene, each link once."""
        return self._call("elastic_energy")

    # --- the workers ---------------------------------------------------------------------------
    def serve(self):
        """Ranks > 0: take part in rank 0's calls until it stops; a failure here stops every
        rank (rank 0 would wait for this one for ever). A stop (SIGTERM, Ctrl-C) is rank 0's
        to handle: it ends its step, says why, and releases the workers."""
        import signal
        for s in (signal.SIGTERM, signal.SIGINT):
            signal.signal(s, signal.SIG_IGN)
        try:
            while True:
                name, args = self._receive()
                if name == _STOP:
                    return
                getattr(self, f"_{name}")(*args)
        except BaseException:
            import traceback
            traceback.print_exc()
            self.comm.Abort(1)

    # --- the collective implementations --------------------------------------------------------
    def _call(self, name, *args):
        self._send((name, args))
        return getattr(self, f"_{name}")(*args)

    def _send(self, call):
        _send(self.comm, call)

    def _receive(self):
        """The next call; a worker idle for a while sleeps between looks rather than spin (as
        a blocking receive does): rank 0 builds and writes on a core the workers share."""
        idle = perf_counter()
        while not self.comm.Iprobe(source=0, tag=_CALL_TAG):
            if perf_counter() - idle > _SPIN:
                sleep(_NAP)
        return self.comm.recv(source=0, tag=_CALL_TAG)

    def _split(self):
        mpy = _mpy()
        mpy.mpirun(1)                   # the split, and the step that makes the links
        _link_factors_back(mpy.O)
        self._own = np.sort(np.asarray(mpy.O.subD.ids if self.rank > 0 else [], int))

    def _step(self, n):
        step = _mpy().O.step        # in this thread: O.run's waiting costs ~10 ms a call
        for _ in range(n):
            step()

    def _states(self, ids):
        from yade.wrapper import Subdomain
        mine = np.flatnonzero(np.isin(ids, self._own))
        values = np.asarray(Subdomain().getStateValuesFromIds(ids[mine].tolist()) if len(mine)
                            else [], float)
        parts = self.comm.gather((mine, values), root=0)
        if self.rank != 0:
            return None
        out = np.full((len(ids), 13), np.nan)
        for where, v in parts:
            out[where] = v.reshape(-1, 13)
        return out

    def _put(self, ids, values):
        """Between steps (the impactor set moving): the owners write the states, send them to
        the ranks that mirror the bodies, and every rank collides again (a body put somewhere
        new may meet bodies it did not before)."""
        from yade.wrapper import Subdomain
        mpy = _mpy()
        mine = np.flatnonzero(np.isin(ids, self._own))
        if len(mine):
            Subdomain().setStateValuesFromIds(ids[mine].tolist(), values[mine].ravel().tolist())
        mpy.sendRecvStates()
        mpy.parallelCollide()

    def _links(self):
        O = import_yade().Omega()
        pairs, omega = [], []
        for i in O.interactions:
            phys = i.phys
            if phys is not None and phys.isCohesive and self._owns(i.id1):
                pairs.append((i.id1, i.id2))
                omega.append(phys.omega)
        parts = self.comm.gather((np.array(pairs, int).reshape(-1, 2), np.array(omega)),
                                 root=0)
        if self.rank != 0:
            return None
        return (np.concatenate([p for p, _ in parts]),
                np.concatenate([w for _, w in parts]))

    def _elastic_energy(self):
        """This rank's links' energy: the law's sum over its interactions less those whose
        first body is another rank's (a mirror body: those are counted by their owner)."""
        from yade_side.scene import cpm_law, link_energy
        O = _mpy().O                # the Omega that holds subD
        law = cpm_law()
        energy = law.elasticEnergy() if law is not None else 0.0
        if self.rank > 0:           # rank 0 has no interaction
            for m in O.subD.mirrorIntersections:
                for body in m:
                    b = O.bodies[body]
                    if b is None or self._owns(body):
                        continue
                    for i in b.intrs():
                        if i.isReal and i.id1 == body and i.phys is not None:
                            energy -= link_energy(i.phys)
        return self.comm.reduce(energy, root=0)

    def _owns(self, body):
        at = np.searchsorted(self._own, body)
        return at < len(self._own) and self._own[at] == body


def _engines_for_mpy(O, verlet):
    """Rank 0, before the split: the labels, Verlet distance and master fix mpy needs (the
    engines go to the workers with the scene)."""
    import yade.wrapper as w
    for e in O.engines:
        if isinstance(e, w.InsertionSortCollider):
            e.label, e.verletDist = "collider", verlet
        if isinstance(e, w.NewtonIntegrator):
            e.label = "newton"
    O.engines = O.engines + [w.PyRunner(
        iterPeriod=1, label="master_fix",
        command="import yade_side.distributed; yade_side.distributed.master_fix()")]


def master_fix():
    """Rank 0 owns no body: its NewtonIntegrator leaves maxVelocitySq at 0, which the collider
    reads as 'run me', and mpy then makes every rank collide at every step. Hold it at the
    value mpy itself sets after a parallel collision (a PyRunner on every rank)."""
    from yade import mpy
    if mpy.rank == 0:
        O = import_yade().Omega()
        O.engines[_newton_index(O)].maxVelocitySq = 0.5


def _newton_index(O):
    import yade.wrapper as w
    return next(k for k, e in enumerate(O.engines) if isinstance(e, w.NewtonIntegrator))


def _link_factors_back(O):
    """After the link step: contacts are detected at touch again (interactionDetectionFactor 1);
    the bounds keep their enlargement (point 4 of the module's note)."""
    import yade.wrapper as w
    for e in O.engines:
        if isinstance(e, w.InteractionLoop):
            for f in e.geomDispatcher.functors:
                f.interactionDetectionFactor = 1.0


def serve():
    """Ranks > 0: own bodies of rank 0's scene and step them until rank 0 stops."""
    from mpi4py import MPI
    RankZeroScene(MPI.COMM_WORLD).serve()


def release_workers_at_exit():
    """Rank 0: however this process ends, the workers leave serve() (once)."""
    from mpi4py import MPI
    atexit.register(_send, MPI.COMM_WORLD, (_STOP, ()))


def _send(comm, call):
    for worker in range(1, comm.size):
        comm.send(call, dest=worker, tag=_CALL_TAG)
