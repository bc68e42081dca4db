"""Bulk state exchange with YADE for a set of bodies, as numpy arrays.

One call reads or writes the 13 state values of every body of the set (pos, vel, angVel,
ori as x, y, z, w) through YADE's C++ `Subdomain.get/setStateValuesFromIds`, which works in a
plain serial scene: no per-body Python in the time loop.
"""
import array

import numpy as np

from yade_side import import_yade

_POS, _VEL, _ANGVEL, _ORI = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 13)


class BodySet:
    """A fixed set of spheres. Attributes read once: ids, mass, inertia (scalar, sphere),
    radius, ref_pos (positions when the set was made). `rotation` accumulates the small-rotation
    vector since then: θ(t+Δt) = θ(t) + Δt ω(t+Δt/2), the central-difference update of the
    rotation that NewtonIntegrator applies to the orientation."""

    def __init__(self, ids):
        yade = import_yade()
        self._O = yade.Omega()
        self._subdomain = yade.wrapper.Subdomain()
        self.ids = np.asarray(ids, dtype=int)
        self._id_list = self.ids.tolist()
        bodies = [self._O.bodies[i] for i in self._id_list]
        self.mass = np.array([b.state.mass for b in bodies])
        self.inertia = np.array([b.state.inertia[0] for b in bodies])
        self.radius = np.array([b.shape.radius for b in bodies])
        self.state = np.empty((len(self.ids), 13))
        self.read()
        self.ref_pos = self.state[:, _POS].copy()
        self.rotation = np.zeros((len(self.ids), 3))
        self.rotation_pred = self.rotation.copy()

    def __len__(self):
        return len(self.ids)

    def read(self):
        # array.array converts YADE's list of floats in C: twice as fast as np.array(list)
        values = array.array("d", self._subdomain.getStateValuesFromIds(self._id_list))
        self.state[:] = np.frombuffer(values, float).reshape(-1, 13)
        return self.state

    def write(self):
        self._subdomain.setStateValuesFromIds(self._id_list, array.array("d", self.state.tobytes()))

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
        self.state[:, _ANGVEL] += dtheta / dt
        self.state[:, _ORI] = quaternion_product(rotation_quaternion(dtheta), self.ori)
        self.rotation[:] = self.rotation_pred + dtheta
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
    angle = np.linalg.norm(theta, axis=1)
    half = 0.5 * angle
    # sin(a/2)/a → 1/2 as a → 0; np.sinc(x) = sin(πx)/(πx)
    s = 0.5 * np.sinc(half / np.pi)
    return np.column_stack([theta * s[:, None], np.cos(half)])


def quaternion_product(p, q):
    """Hamilton products p q of quaternions stored (x, y, z, w), row by row."""
    pv, pw = p[:, :3], p[:, 3:]
    qv, qw = q[:, :3], q[:, 3:]
    return np.column_stack([pw * qv + qw * pv + np.cross(pv, qv),
                            pw * qw - np.einsum("ij,ij->i", pv, qv)[:, None]])
