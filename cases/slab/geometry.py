"""The slab's geometry: its FE grid and DE zone, the packings of slab and impactor, the sensor
points, the bridging band."""
from dataclasses import dataclass

import numpy as np

from cases.slab.scales import SLAB
from orchestrator.coupling.bridging import BoxZone, Bridging
from orchestrator.coupling.cells import CellGrid


@dataclass
class Grid:
    """The FE grid of the slab (square in-plane cells of size h) and the DE zone on it."""
    h: float
    n: tuple
    hole_lo: np.ndarray
    hole_hi: np.ndarray
    axes: tuple = (0, 1)  # the axes along which the DE zone is bounded
    cells: np.ndarray = None  # a DE zone of in-plane grid cells (nx, ny) mask (hole_*: its
                              # bounding box), else the box [hole_lo, hole_hi]
    h_band: float = None      # a graded mesh: the band's cells (None: uniform cells of h)
    layers: int = 0           # a graded mesh: the band's cells of h_band on each side

    @property
    def width(self):
        return self.hole_hi - self.hole_lo

    @property
    def band_h(self):
        """The in-plane size of the bridging band's cells."""
        return self.h if self.h_band is None else self.h_band


GROWTH = 1.2   # a graded mesh's largest ratio of neighbouring cells (docs/performance.md)


def fe_axes(grid):
    """The FE grid's planes along x, y, z: uniform, or graded along the zone's axes from the
    band's cells to h (fenicsx_side.mesh.graded_axis)."""
    axes = [np.linspace(0.0, SLAB[i], grid.n[i] + 1) for i in range(3)]
    if grid.h_band is not None:
        from fenicsx_side.mesh import graded_axis
        for i in grid.axes:
            axes[i] = graded_axis(0.0, SLAB[i], grid.hole_lo[i], grid.hole_hi[i], grid.h_band,
                                  grid.layers, GROWTH, h_max=grid.h)
    return axes


def slab_grid(spec):
    """In-plane size h = 0.5/k m closest to fe_ratio × diameter, so that both 2.5 m and 2 m
    are whole numbers of cells; DE zone = the central block of cells nearest de_zone (along x
    only with full_width)."""
    h = plan_cell({"fe_ratio": spec.fe_ratio, "radius": spec.radius})
    n = [round(SLAB[0] / h), round(SLAB[1] / h),
         max(1, round(SLAB[2] / (spec.fe_ratio_thickness * 2 * spec.radius)))]
    lo, hi = np.zeros(3), np.array(SLAB)
    axes = (0,) if spec.full_width else (0, 1)
    for axis in axes:
        cells = max(1, round(spec.de_zone / h))
        if (n[axis] - cells) % 2:  # centred on the slab
            cells += 1
        start = (n[axis] - cells) // 2
        if start < spec.layers + 1:
            raise ValueError(f"slab: a DE zone of {cells} cells and {spec.layers} bridging "
                             f"layers do not fit in the {n[axis]} cells along axis {axis} with "
                             f"FE beyond them; reduce de_zone or layers, or the sphere radius")
        lo[axis], hi[axis] = start * h, (start + cells) * h
    if spec.band_ratio is None:
        return Grid(h, tuple(n), lo, hi, axes)
    return Grid(h, tuple(n), lo, hi, axes, h_band=spec.band_ratio * 2 * spec.radius,
                layers=spec.layers)


@dataclass
class Packings:
    slab_centres: np.ndarray
    slab_radii: np.ndarray
    slab_fraction: float
    impactor_centres: np.ndarray
    impactor_radii: np.ndarray
    impactor_drop: float  # lowered by this once the cohesive links are made: spec.impactor_gap


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


def plan_cell(spec):
    """The in-plane size h of the slab's FE cells (slab_grid's) for a spec given as a dict
    (summary.json's): a plan grid of h puts each FE cell in a grid cell of its own."""
    k = max(1, round(0.5 / (spec["fe_ratio"] * 2 * spec["radius"])))
    return 0.5 / k


def sensor_points(spec, grid):
    xc, yc = 0.5 * SLAB[0], 0.5 * SLAB[1]
    zmid = 0.5 * SLAB[2]
    w = spec.layers * grid.band_h
    away = 0.5 * (xc + 0.5 * spec.impactor_side + grid.hole_hi[0])
    return {
        "under_impact": (xc, yc, spec.radius),
        "de_zone": (away, yc, zmid),
        "bridging": (grid.hole_hi[0] + 0.5 * w, yc, zmid),
    }


def cell_grid(grid):
    """The slab's in-plane grid of FE cells, on which DE zones of cells are masks."""
    return CellGrid((0.0, 0.0, 0.0), SLAB, grid.n, axes=(0, 1))


def slab_bridging(spec, grid):
    zone = (BoxZone(grid.hole_lo, grid.hole_hi, grid.axes) if grid.cells is None
            else cell_grid(grid).zone(grid.cells))
    return Bridging(zone, spec.layers, grid.band_h)
