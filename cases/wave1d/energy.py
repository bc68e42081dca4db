"""Energies of the 1D model: leap-frog invariants of a lattice region, split by frequency."""
import math

import numpy as np


def lattice_energy(d0, d1, dt, mass, stiffness, omega_split):
    """Leap-frog invariant ½ m v² + ½ k Δd₀ Δd₁ (v = (d1 − d0)/Δt) of a uniform lattice
    segment, split at ω_split by its discrete Fourier modes (periodic wrap: the segment must
    be at rest near both ends). Returns (low, high)."""
    n = len(d0)
    v = np.fft.rfft((d1 - d0) / dt)
    f0, f1 = np.fft.rfft(d0), np.fft.rfft(d1)
    kappa_s = 2 * np.pi * np.arange(len(v)) / n         # κ × spacing
    w = np.full(len(v), 2.0)                            # rfft: each interior mode counts twice
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    spring = 4 * np.sin(kappa_s / 2) ** 2               # |e^{iκs} − 1|²
    e = 0.5 * w / n * (mass * np.abs(v) ** 2 + stiffness * spring * (f0 * np.conj(f1)).real)
    low = 2 * math.sqrt(stiffness / mass) * np.sin(kappa_s / 2) < omega_split
    return float(e[low].sum()), float(e[~low].sum())


def weighted_invariant(d0, d1, dt, mass, stiffness, x, points, links, weight,
                       point_weight=None):
    """Leap-frog invariant Σ w ½ m v² over `points` (mask) + Σ w ½ k Δd₀ Δd₁ over `links`
    (index i: the link of points i, i+1) of a lattice at positions x along the axis, with
    the bridging weight w(x) (α or β) at the links' midpoints and `point_weight(x)` (default
    the same) at the points."""
    on_axis = lambda xs: np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    point_weight = weight if point_weight is None else point_weight
    v = (d1[points] - d0[points]) / dt
    kinetic = np.sum(point_weight(on_axis(x[points])) * np.broadcast_to(mass, x.shape)[points]
                     * v * v)
    w_links = weight(on_axis(0.5 * (x[links] + x[links + 1])))
    strain = np.sum(w_links * (d0[links + 1] - d0[links]) * (d1[links + 1] - d1[links]))
    return float(0.5 * kinetic + 0.5 * stiffness * strain)
