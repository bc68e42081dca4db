"""Bulk state exchange with YADE for a set of bodies, as numpy arrays.

One call reads or writes the 13 state values of every body of the set (pos, vel, angVel,
ori as x, y, z, w): by a numpy gather/scatter in YADE's memory when its layout is verified
(yade_side.memory), else through YADE's C++ `Subdomain.get/setStateValuesFromIds`, which
works in a plain serial scene. No per-body Python in the time loop either way. Once a scene
is split over MPI ranks (yade_side.distributed), they go to the bodies' owners.
"""
import array
import weakref

import numpy as np

from yade_side import import_yade
from yade_side.distributed import remote
from yade_side.memory import SceneReplaced, locate

_POS, _VEL, _ANGVEL, _ORI = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 13)
_LIVE = weakref.WeakSet()  # every BodySet, to reattach after a scene is loaded


def reattach_all():
    for body_set in list(_LIVE):
        body_set.reattach()


class BodySet:
    """A fixed set of spheres. Attributes read once: ids, mass, inertia (scalar, sphere),
    radius, ref_pos (positions when the set was made, or those given). `rotation` accumulates
    the small-rotation vector since then: θ(t+Δt) = θ(t) + Δt ω(t+Δt/2), the central-difference
    update of the rotation that NewtonIntegrator applies to the orientation."""

    def __init__(self, ids, direct=True, ref_pos=None, _known=None):
        yade = import_yade()
        self._O = yade.Omega()
        self._subdomain = yade.wrapper.Subdomain()
        self.ids = np.asarray(ids, dtype=int)
        self._id_list = self.ids.tolist()
        bodies = [self._O.bodies[i] for i in self._id_list]
        self.mass = np.array([b.state.mass for b in bodies])
        self.inertia = np.array([b.state.inertia[0] for b in bodies])
        self.state = np.empty((len(self.ids), 13))
        self._direct = direct
        if _known is None:
            self.radius = np.array([b.shape.radius for b in bodies])
            self.reattach()
        else:                           # (joined, subset)
            self.radius, self._memory = _known
            self._orphaned = False
        self.read()
        self.ref_pos = (self.state[:, _POS].copy() if ref_pos is None
                        else np.array(ref_pos, float).reshape(-1, 3))
        self.rotation = np.zeros((len(self.ids), 3))
        self.rotation_pred = self.rotation.copy()
        _LIVE.add(self)

    def reattach(self):
        """Find the bodies' states in YADE's memory again: after O.load() they are new
        objects, and a view of the old ones would read and write bodies no longer simulated.
        A set whose bodies the new scene does not have (a set of an earlier scene) is left
        orphaned: reading or writing it raises SceneReplaced."""
        self._memory, self._orphaned = None, False
        bodies = self._O.bodies
        if any(i >= len(bodies) or bodies[i] is None for i in self._id_list):
            self._orphaned = True
        elif self._direct:
            self._memory = locate(self._O, self._id_list, self._api_get, self._api_put)

    @classmethod
    def joined(cls, first, second, ref_pos=None):
        """The set of the bodies of `first` then of `second`, sets of the current scene:
        masses and inertias read now (weights may have changed), radii and places in YADE's
        memory theirs (verified when they were found; a body set finds them afresh after a
        scene is loaded)."""
        memory = (first._memory.joined(second._memory)
                  if first._memory is not None and second._memory is not None else None)
        if memory is None and first._direct and len(second):
            return cls(np.concatenate([first.ids, second.ids]), ref_pos=ref_pos)
        return cls(np.concatenate([first.ids, second.ids]), first._direct, ref_pos,
                   (np.concatenate([first.radius, second.radius]), memory))

    def subset(self, rows, ref_pos=None):
        """The set of the bodies `rows` of this one (as joined: masses read now)."""
        rows = np.asarray(rows, int)
        memory = self._memory.taken(rows) if self._memory is not None and len(rows) else None
        return type(self)(self.ids[rows], self._direct, ref_pos, (self.radius[rows], memory))

    def __len__(self):
        return len(self.ids)

    @property
    def direct(self):
        """True when reads and writes go straight to YADE's memory."""
        return self._memory is not None

    def read(self):
        self._check_attached()
        if remote() is not None:
            self.state[:] = remote().states(self.ids)
        elif self._memory is not None:
            self._memory.read(self.state)
        else:
            # array.array converts YADE's list of floats in C: twice as fast as np.array(list)
            values = array.array("d", self._api_get(self._id_list))
            self.state[:] = np.frombuffer(values, float).reshape(-1, 13)
        return self.state

    def write(self):
        self._check_attached()
        if remote() is not None:
            remote().put(self.ids, self.state)
        elif self._memory is not None:
            self._memory.write(self.state)
        else:
            self._api_put(self._id_list, self.state.ravel().tolist())

    def _check_attached(self):
        if self._orphaned:
            raise SceneReplaced("this body set's bodies are not in the current YADE scene (it "
                                "was made for an earlier scene)")

    def _api_get(self, ids):
        return self._subdomain.getStateValuesFromIds(ids)

    def _api_put(self, ids, values):
        self._subdomain.setStateValuesFromIds(ids, values)

    @property
    def pos(self):
        return self.state[:, _POS]

    @property
    def vel(self):
        return self.state[:, _VEL]

    @property
    def angvel(self):
        return self.state[:, _ANGVEL]

    @property
    def ori(self):
        return self.state[:, _ORI]

    def displacement(self):
        return self.state[:, _POS] - self.ref_pos

    def predict(self, dt):
        """Read the state YADE's step left (the central-difference predictor) and predict θ."""
        self.read()
        np.add(self.rotation, dt * self.angvel, out=self.rotation_pred)

    def correct(self, dd, dtheta, dt):
        """Add dd to positions and dd/Δt to half-step velocities (same for rotations, and the
        orientation turned by dθ): the step stays an exact central difference. One write."""
        self.state[:, _POS] += dd
        self.state[:, _VEL] += dd / dt
        np.add(self.rotation_pred, dtheta, out=self.rotation)
        if dtheta.any():  # rotations coupled
            self.state[:, _ANGVEL] += dtheta / dt
            self.state[:, _ORI] = quaternion_product(rotation_quaternion(dtheta), self.ori)
        self.write()

    def move(self, offset):
        """Translate the set rigidly before a run (ref_pos moves with it)."""
        self.read()
        self.state[:, _POS] += offset
        self.ref_pos += offset
        self.write()

    def set_velocity(self, vel, angvel=None):
        self.read()
        self.state[:, _VEL] = vel
        if angvel is not None:
            self.state[:, _ANGVEL] = angvel
        self.write()

    def kinetic_energy(self):
        """½ Σ (m v² + J ω²) with the half-step velocities of the last read."""
        return 0.5 * float(self.mass @ np.einsum("ij,ij->i", self.vel, self.vel)
                           + self.inertia @ np.einsum("ij,ij->i", self.angvel, self.angvel))


def rotation_quaternion(theta):
    """Unit quaternions (x, y, z, w) of the rotation vectors theta (n, 3)."""
    angle = np.sqrt(np.einsum("ij,ij->i", theta, theta))
    half = 0.5 * angle
    # sin(a/2)/a, → 1/2 as a → 0
    s = np.divide(np.sin(half), angle, out=np.full(len(angle), 0.5), where=angle > 0)
    q = np.empty((len(theta), 4))
    np.multiply(theta, s[:, None], out=q[:, :3])
    np.cos(half, out=q[:, 3])
    return q


def quaternion_product(p, q):
    """Hamilton products p q of quaternions stored (x, y, z, w), row by row."""
    (px, py, pz, pw), (qx, qy, qz, qw) = p.T, q.T
    pq = np.empty((4, len(p)))
    pq[0] = pw * qx + qw * px + py * qz - pz * qy
    pq[1] = pw * qy + qw * py + pz * qx - px * qz
    pq[2] = pw * qz + qw * pz + px * qy - py * qx
    pq[3] = pw * qw - px * qx - py * qy - pz * qz
    return pq.T
