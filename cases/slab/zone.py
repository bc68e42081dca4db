"""The slab's FE grid and its DE zone: the structured grid (uniform, or graded towards the
band), the box zone of the spec or a zone of in-plane cells, the start and limit of a zone that
grows (`--zone grow|auto`, cases.slab.grow, cases.slab.search) and its trip levels, the
bridging band, and the sensor points the zone places."""
from dataclasses import dataclass, replace

import numpy as np

from cases.slab.scales import SLAB
from orchestrator.coupling.bridging import BoxZone, Bridging
from orchestrator.coupling.cells import CellGrid
from orchestrator.run.autozone import TripLevels, check_zones


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


def plan_cell(spec):
    """The in-plane size h of the slab's FE cells (slab_grid's) for a spec given as a dict
    (summary.json's): a plan grid of h puts each FE cell in a grid cell of its own."""
    k = max(1, round(0.5 / (spec["fe_ratio"] * 2 * spec["radius"])))
    return 0.5 / k


def slab_grid(spec):
    """In-plane size h = 0.5/k m closest to fe_ratio × diameter, so that both 2.5 m and 2 m
    are whole numbers of cells; DE zone = the central block of cells nearest de_zone (along x
    only with full_width)."""
    h = plan_cell({"fe_ratio": spec.fe_ratio, "radius": spec.radius})
    n = [round(SLAB[0] / h), round(SLAB[1] / h),
         max(1, round(SLAB[2] / (spec.fe_ratio_thickness * 2 * spec.radius)))]
    lo, hi = np.zeros(3), np.array(SLAB)
    axes = (0,) if spec.full_width else (0, 1)
    h_band = h if spec.band_ratio is None else spec.band_ratio * 2 * spec.radius
    for axis in axes:
        cells = max(1, round(spec.de_zone / h))
        if (n[axis] - cells) % 2:  # centred on the slab
            cells += 1
        start = (n[axis] - cells) // 2
        # the band's layers and at least one FE cell of the band's size beyond them
        if start * h < (spec.layers + 1) * h_band * (1 - 1e-9):
            raise ValueError(f"slab: a DE zone of {cells} cells and {spec.layers} bridging "
                             f"layers of {h_band:.4g} m do not fit in the {n[axis]} cells of "
                             f"{h:.4g} m along axis {axis} with FE beyond them; reduce de_zone "
                             f"or layers, or the sphere radius")
        lo[axis], hi[axis] = start * h, (start + cells) * h
    if spec.band_ratio is None:
        return Grid(h, tuple(n), lo, hi, axes)
    return Grid(h, tuple(n), lo, hi, axes, h_band=h_band, layers=spec.layers)


def cell_grid(grid):
    """The slab's in-plane grid of FE cells, on which DE zones of cells are masks."""
    return CellGrid((0.0, 0.0, 0.0), SLAB, grid.n, axes=(0, 1))


def zone_grid(base, mask):
    """The slab's grid with the DE zone of cells `mask` (hole_lo/hi: its bounding box)."""
    lo, hi = cell_grid(base).boxes(mask)
    return Grid(base.h, base.n, lo.min(axis=0), hi.max(axis=0), (0, 1), cells=mask)


def model_grid(spec):
    """The grid of the coupled model of `spec` with a fixed zone: its zone_cells, or its box."""
    return slab_grid(spec) if spec.zone_cells is None else cells_grid(spec, spec.zone_cells)


def cells_grid(spec, cells):
    """The slab grid of `spec` with the DE zone of in-plane cells `cells` (grid indices, as
    summary.json's zone_final records them)."""
    base = slab_grid(spec)
    mask = np.zeros(cell_grid(base).shape, bool)
    mask[tuple(np.asarray(cells, int).reshape(-1, 2).T)] = True
    return zone_grid(base, mask)


def _centred(spec, side, full_width, name):
    """Mask of the centred zone slab_grid makes of a DE zone of `side` m."""
    try:
        g = slab_grid(replace(spec, de_zone=side, full_width=full_width, zone="box"))
    except ValueError as e:
        raise ValueError(f"slab: {name} = {side!r} m: {str(e).removeprefix('slab: ')}") from None
    return cell_grid(g).box_mask(g.hole_lo, g.hole_hi)


def start_zone(spec):
    if spec.zone_start is None:
        return _centred(spec, spec.de_zone, spec.full_width, "de_zone")
    return _centred(spec, spec.zone_start, False, "zone.start")


def limit_zone(spec):
    """The cells the zone may fill: a full-width strip along x that leaves the bridging band
    and one FE cell before each support (slab_grid's rule)."""
    if spec.zone_limit is not None:
        return _centred(spec, spec.zone_limit, True, "zone.limit")
    base = slab_grid(spec)
    mask = np.zeros(cell_grid(base).shape, bool)
    mask[spec.layers + 1: base.n[0] - spec.layers - 1] = True
    return mask


def levels(spec):
    return TripLevels(spec.trip_stress, spec.trip_omega, spec.trip_damage, spec.stress_every,
                      spec.links_every, spec.zone_margin, spec.zone_ahead, spec.trip_band)


def check(spec):
    """The auto-zone options of `spec`, checked: (base grid, start, limit, trip levels)."""
    if spec.zone == "grow" and spec.reinforced:
        raise ValueError("slab: zone 'grow' does not carry the bars' state to a grown zone: "
                         "run the reinforced slab with zone 'box' or 'auto'")
    base = slab_grid(spec)
    start, limit = start_zone(spec), limit_zone(spec)
    try:
        check_zones(cell_grid(base), start, limit)
    except ValueError as e:
        raise ValueError(f"slab: {e}") from None
    return base, start, limit, levels(spec)


def slab_bridging(spec, grid):
    zone = (BoxZone(grid.hole_lo, grid.hole_hi, grid.axes) if grid.cells is None
            else cell_grid(grid).zone(grid.cells))
    return Bridging(zone, spec.layers, grid.band_h)


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
