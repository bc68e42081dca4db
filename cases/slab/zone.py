"""The slab's DE zone found by the coupled run itself (`--zone auto`, orchestrator.run.autozone):
zones are masks of the slab's in-plane FE cells, through the thickness. It starts from the
spec's box zone (or a square of side zone_start under the impact) and may grow up to a
full-width strip along x, by default the slab less the supports and the bridging band.

Results folder: attempt-K/ holds each tripped attempt (run.log and what it wrote before its
trip); the last attempt's results are the folder's own, with summary.json recording the
search and zones.png the zones grown over the slab's plan.
"""
from dataclasses import asdict, replace

import numpy as np

from cases.slab.geometry import Grid, cell_grid, slab_grid
from orchestrator.run.autozone import TripLevels, check_zones, find_zone, plot_zones


def zone_grid(base, mask):
    """The slab's grid with the DE zone of cells `mask` (hole_lo/hi: its bounding box)."""
    lo, hi = cell_grid(base).boxes(mask)
    return Grid(base.h, base.n, lo.min(axis=0), hi.max(axis=0), (0, 1), cells=mask)


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
    return TripLevels(spec.trip_stress, spec.trip_omega, spec.stress_every, spec.links_every,
                      spec.zone_margin)


def check(spec):
    """The auto-zone options of `spec`, checked: (base grid, start, limit, trip levels)."""
    base = slab_grid(spec)
    start, limit = start_zone(spec), limit_zone(spec)
    try:
        check_zones(cell_grid(base), start, limit)
    except ValueError as e:
        raise ValueError(f"slab: {e}") from None
    return base, start, limit, levels(spec)


def run_auto(spec, out, quiet=False):
    """Attempts of the coupled slab until one runs clean or the zone would pass its limit
    (then the full model with fallback = "full"); returns the summary written in `out`."""
    from cases.slab.model import SlabModel, run, run_built
    from common.files import write_json
    base, start, limit, lv = check(spec)
    grid = cell_grid(base)
    full_spheres = []

    def build(mask):
        m = SlabModel(spec, "coupled", zone_grid(base, mask))
        full_spheres[:] = [len(m.scene.packs.slab_radii) + len(m.impactor_ids)]
        return m

    def attempt(model, k):
        folder = out / f"attempt-{k + 1}"
        folder.mkdir()
        return run_built(model, folder, quiet)

    outcome = find_zone(build, attempt, grid, start, limit, spec.tensile_strength, lv,
                        log=lambda line: None if quiet else print(line),
                        budget=lambda attempts: over_budget(attempts, full_spheres[0], spec))
    record = outcome.record(grid, full_spheres[0], spec.steps)
    last = out / f"attempt-{len(outcome.attempts)}"
    if outcome.status == "clean":
        for entry in last.iterdir():        # the last attempt's results are the folder's own
            entry.rename(out / entry.name)
        last.rmdir()
        summary = outcome.summary
    else:
        record["zone_message"] = message(outcome, full_spheres[0], record)
        print(record["zone_message"])
        summary = {"model": "coupled", "spec": asdict(spec)}
        if spec.fallback == "full":
            full_out = out / "full"
            full_out.mkdir()
            summary = run(replace(spec, zone="box"), "full", full_out, quiet)
            for entry in list(full_out.iterdir()):
                entry.rename(out / entry.name)
            full_out.rmdir()
            summary["zone_fallback"] = "full"
    summary.update(record)
    write_json(out / "summary.json", summary)
    plot_zones(out / "zones.png", grid, outcome, limit, f"slab {spec.scale}, "
               f"{spec.impactor_speed:g} m/s")
    return summary


def search_cost(attempts, steps):
    """(sphere steps run by the attempts, those of one whole run of the last zone): the
    search's cost in YADE's unit of work, the same on every machine (the next zone holds at
    least the last one's spheres)."""
    return (sum(a["spheres"] * a["steps_run"] for a in attempts),
            attempts[-1]["spheres"] * steps)


def over_budget(attempts, full_spheres, spec):
    """Why another attempt cannot pay (None if it still can): the sphere steps spent, plus one
    whole run of the last zone, reach zone_cost × the full model's (zone_cost 0: never)."""
    spent, next_run = search_cost(attempts, spec.steps)
    full = full_spheres * spec.steps
    if not spec.zone_cost or spent + next_run < spec.zone_cost * full:
        return None
    return (f"{spent:.4g} sphere steps spent and at least {next_run:.4g} for the next attempt "
            f"reach zone.cost = {spec.zone_cost:g} × the full model's {full:.4g}")


def message(outcome, full_spheres, record):
    a = outcome.attempts[-1]
    why = ("would pass its limit" if outcome.limit == "cells" else
           "would cost more than the full model (zone.cost) in another attempt")
    return (f"coupling cannot pay for this impact: after {len(outcome.attempts)} attempts the "
            f"DE zone ({a['cells']} of {outcome.zone.size} in-plane cells, {a['spheres']} of "
            f"the full model's {full_spheres} spheres) {why}; "
            f"{outcome.wall_s:.3g} s spent against a projected "
            f"{record['full_model_projected']['wall_s']:.3g} s for the full model")

