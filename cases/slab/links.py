"""What a full slab run records of its links at its end: how many are damaged or broken, and
how many of those lie outside the DE zone a coupled model of the same slab would have
(summary.json `links_outside_de_zone`; cases.slab.variants reads it)."""
import numpy as np

DAMAGED_OMEGA = 0.1    # a link "partly damaged" beyond this CPM damage ω


def link_record(omega, outside, level=DAMAGED_OMEGA):
    """What a full run records of its links (summary.json `links_outside_de_zone`): omega the
    CPM damage of every initial link (a broken one counting as 1), outside whether its
    midpoint lies outside the DE zone."""
    omega, outside = np.asarray(omega, float), np.asarray(outside, bool)
    if omega.shape != outside.shape or omega.ndim != 1:
        raise ValueError(f"links: {omega.size} damages for {outside.size} positions")
    damaged, broken = omega > level, omega >= 1.0
    count = lambda mask: int(np.count_nonzero(mask))
    return {"level_omega": level, "links": count(outside), "links_total": omega.size,
            "damaged": count(damaged & outside), "damaged_total": count(damaged),
            "broken": count(broken & outside), "broken_total": count(broken),
            "damaged_share_outside": share(count(damaged & outside), count(damaged))}


def share(part, whole):
    return None if whole == 0 else part / whole
