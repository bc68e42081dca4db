"""The slab's and the impactor's sphere packings."""
from dataclasses import dataclass

import numpy as np

from cases.slab.scales import SLAB


@dataclass
class Packings:
    slab_centres: np.ndarray
    slab_radii: np.ndarray
    slab_fraction: float
    impactor_centres: np.ndarray
    impactor_radii: np.ndarray
    impactor_drop: float  # lowered by this once the cohesive links are made: spec.impactor_gap


def supported(c, r):
    """Mask of the slab's spheres (centres c, radii r) the full model holds in z: those within
    two radii of the x = 0 and x = 2.5 faces (simple supports)."""
    return (c[:, 0] < 2 * r) | (c[:, 0] > SLAB[0] - 2 * r)


def support_line(c, r):
    """Where the full model's supports act: the mean distance of its held spheres' centres
    from their end face (m)."""
    held = supported(c, r)
    return float(np.minimum(c[held, 0], SLAB[0] - c[held, 0]).mean())


def make_packings(spec):
    """The slab's and the impactor's spheres. The impactor sits 1.05 × beyond the reach of the
    cohesive links made in the first step (1.5 × the sum of radii: no link joins it to the
    slab); lowered by impactor_drop after that step, it touches the slab after a fall of
    impactor_gap."""
    from yade_side.packing import dense_box_packing, packing_fraction, sphere_arrays
    from yade_side.scene import INTERACTION_RADIUS
    slab_c, slab_r = sphere_arrays(dense_box_packing((0, 0, 0), SLAB, spec.radius,
                                                     seed=spec.seed))
    a = spec.impactor_side
    imp_c, imp_r = sphere_arrays(dense_box_packing((0, 0, 0), (a, a, a), spec.radius,
                                                   seed=spec.seed + 1))
    imp_c = imp_c + [0.5 * (SLAB[0] - a), 0.5 * (SLAB[1] - a), -np.min(imp_c[:, 2])]
    lift = _impactor_height(imp_c, imp_r, slab_c, slab_r, 1.05 * INTERACTION_RADIUS)
    touch = _impactor_height(imp_c, imp_r, slab_c, slab_r, 1.0)
    imp_c[:, 2] += lift
    return Packings(slab_c, slab_r, packing_fraction(slab_r, np.prod(SLAB)), imp_c, imp_r,
                    lift - touch - spec.impactor_gap)


def _impactor_height(imp_c, imp_r, slab_c, slab_r, reach):
    """The lowest lift of the impactor (centred over the slab, lowest centre at z = 0) that
    keeps every impactor-slab pair at least `reach` × its sum of radii apart."""
    reach_max = reach * 2 * max(imp_r.max(), slab_r.max())
    lo, hi = imp_c[:, :2].min(axis=0) - reach_max, imp_c[:, :2].max(axis=0) + reach_max
    near = np.all((slab_c[:, :2] > lo) & (slab_c[:, :2] < hi), axis=1)
    near &= slab_c[:, 2] > slab_c[near, 2].max() - reach_max
    low = imp_c[:, 2] < reach_max
    s_c, i_c = slab_c[near], imp_c[low]
    pair_reach = reach * (imp_r[low][:, None] + slab_r[near][None, :])
    lateral = np.linalg.norm(i_c[:, None, :2] - s_c[None, :, :2], axis=2)
    rise = np.sqrt(np.maximum(pair_reach**2 - lateral**2, 0.0))  # vertical centre gap needed
    rise = np.where(lateral < pair_reach, rise + s_c[None, :, 2] - i_c[:, None, 2], -np.inf)
    return float(rise.max())
