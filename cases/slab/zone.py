"""The slab's automatic DE zone (`--zone auto`, orchestrator.run.autozone), its cells and
checks: zones are masks of the slab's in-plane FE cells, through the thickness. It starts
from the spec's box zone (or a square of side zone_start under the impact) and may grow up
to a full-width strip along x, by default the slab less the supports and the bridging band.
The search that runs the attempts is cases.slab.search."""
from dataclasses import replace

import numpy as np

from cases.slab.geometry import Grid, cell_grid, slab_grid
from orchestrator.run.autozone import TripLevels, check_zones


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
                      spec.links_every, spec.zone_margin, spec.zone_ahead)


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
