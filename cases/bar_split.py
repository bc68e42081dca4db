"""Bars cut at a coupled model's DE zone: each model carries the part of a bar where it has
concrete, both in the bridging band, as the concrete.

`split_at_zone(bars, bridging)` cuts every bar where its depth s out of the DE zone crosses 0,
f w, (1 − f) w and w (w the band's width, f the weights' floor: where α and β have kinks), so
that the weights are linear along each piece of a straight bar through a box zone. The DE part
(s ≤ w: the DE zone and the band) keeps each run of pieces as one bar (one chain of spheres);
the FE part (s ≥ 0: the band and beyond) keeps the pieces (truss elements need no continuity:
their ends follow the FE field). Pure numpy.
"""
import numpy as np

from cases.reinforcement import Bars
from orchestrator.coupling.bridging import WEIGHT_FLOOR

SAMPLES_PER_WIDTH = 100      # depth samples per band width along a bar, to bracket the cuts
BISECTIONS = 60              # halvings of a bracket: the cut to machine precision


def split_at_zone(bars, bridging):
    """(DE bars, FE bars) of `bars` for a coupled model with `bridging`; either may be None
    (no bar there). Each piece keeps its bar's properties and layer."""
    w = bridging.width
    levels = np.array([0.0, WEIGHT_FLOOR * w, (1 - WEIGHT_FLOOR) * w, w])
    de, fe = [], []          # (bar index, t0, t1) along bar i's axis, t in [0, 1]
    for i in range(len(bars)):               # per bar: set-up only
        cuts = _cuts(bars.start[i], bars.end[i], bridging.zone.depth, levels,
                     max(2, int(np.ceil(bars.length[i] / w * SAMPLES_PER_WIDTH)) + 1))
        mids = 0.5 * (cuts[:-1] + cuts[1:])
        s = bridging.zone.depth(bars.start[i] + mids[:, None] * (bars.end[i] - bars.start[i]))
        fe += [(i, a, b) for a, b, d in zip(cuts[:-1], cuts[1:], s) if d >= 0]
        run = None
        for a, b, d in zip(cuts[:-1], cuts[1:], s):
            if d <= w:
                run = (i, a, b) if run is None else (i, run[1], b)
            elif run is not None:
                de.append(run)
                run = None
        if run is not None:
            de.append(run)
    return _pieces(bars, de), _pieces(bars, fe)


def _cuts(p0, p1, depth, levels, n):
    """0, 1 and the t in (0, 1) where depth(p0 + t (p1 − p0)) crosses a level, sorted."""
    t = np.linspace(0.0, 1.0, n)
    at = lambda t: depth(p0 + np.asarray(t)[:, None] * (p1 - p0))
    g = at(t)[:, None] - levels[None, :]
    k, j = np.nonzero((g[:-1] >= 0) != (g[1:] >= 0))
    lo, hi = t[k], t[k + 1]
    below = g[k, j] < 0                      # the sign at lo
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        same = (at(mid) - levels[j] < 0) == below
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return np.unique(np.concatenate([[0.0, 1.0], 0.5 * (lo + hi)]))


def _pieces(bars, parts):
    if not parts:
        return None
    i = np.array([p[0] for p in parts], int)
    t0, t1 = (np.array([p[k] for p in parts])[:, None] for k in (1, 2))
    d = bars.end[i] - bars.start[i]
    return Bars(bars.start[i] + t0 * d, bars.start[i] + t1 * d, bars.diameter[i], bars.young[i],
                bars.yield_strength[i], bars.density[i], bars.bond_strength[i], bars.layer[i],
                bars.hardening[i])
