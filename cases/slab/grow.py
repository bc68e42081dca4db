"""The slab's DE zone grown during the run (`--zone grow`, orchestrator.run.grow): the same
start zone, limit, trip levels and budget as `--zone auto` (cases.slab.zone), but a trip
converts the flagged cells and the run goes on from the same step.

Results folder: the run's results as any slab run's, the FE series in fe.xdmf and then one
file per zone (fe-zone2.xdmf, …); summary.json records each conversion (`zone_conversions`)
and zones.png the zone's growth over the slab's plan. When the zone cannot grow further (its
limit, or the budget), one line says that coupling cannot pay for this impact; what the run
wrote until then is kept in stopped/, and with fallback "full" the full model runs in the
folder.
"""
from types import SimpleNamespace

import numpy as np

from cases.slab.geometry import cell_grid
from cases.slab.model import SlabModel, run_built
from cases.slab.search import cannot_pay, fallback
from cases.slab.zone import check, zone_grid
from common.files import write_json
from orchestrator.run.autozone import plot_zones
from orchestrator.run.grow import GrowingModel, ZoneLimit


def run_grow(spec, out, quiet=False):
    """The coupled slab with a zone grown during the run; returns the summary written in
    `out`."""
    base, start, limit, levels = check(spec)
    grid = cell_grid(base)
    dt = None                   # every zone's model takes the first one's time step

    def build(mask):
        nonlocal dt
        m = SlabModel(spec, "coupled", zone_grid(base, mask), dt)
        dt = m.dt
        return m

    say = (lambda line: None) if quiet else print
    model = GrowingModel(build, grid, start, limit, spec.tensile_strength, levels,
                         tol=1e-6 * spec.radius, log=say, shear=spec.grow_shear,
                         budget=lambda segments, n: over_budget(segments, n, full_spheres,
                                                                spec))
    full_spheres = len(model.scene.packs.slab_radii) + len(model.impactor_ids)
    try:
        summary = run_built(model, out, quiet)
        outcome, limit_reached = "clean", None
    except ZoneLimit as e:
        stopped = out / "stopped"
        stopped.mkdir()
        for entry in list(out.iterdir()):
            if entry != stopped and not entry.name.startswith("."):    # the folder's marker
                entry.rename(stopped / entry.name)
        outcome, limit_reached = "limit", e.reached
        message = cannot_pay(
            f"after {len(model.conversions)} conversions during the run, at step "
            f"{e.tripped.step} ({e.tripped.indicator}), {e.reason} (DE zone "
            f"{int(model.zone.sum())} of {model.zone.size} in-plane cells, "
            f"{model.sphere_count()} of the full model's {full_spheres} spheres)")
        print(message)
        summary = {**fallback(spec, out, quiet), "zone_message": message}
    summary.update(model.record(spec.steps), zone_outcome=outcome,
                   zone_limit_reached=limit_reached, zone_full_model_spheres=full_spheres,
                   zone_full_model_sphere_steps=full_spheres * spec.steps)
    summary["zone_final"]["grid"] = {"p0": grid.p0.tolist(), "p1": grid.p1.tolist(),
                                     "n": grid.n.tolist(), "axes": grid.axes}
    if outcome == "clean":
        summary.update(n_slab_spheres=len(model.slab_ids),
                       zone_cells=np.argwhere(model.zone).tolist())
    write_json(out / "summary.json", summary)
    plot_zones(out / "zones.png", grid, SimpleNamespace(zones=model.zones, status=outcome),
               limit, f"slab {spec.scale}, {spec.impactor_speed:g} m/s, grown during the run",
               joined="zone the cell joined (1: the start)")
    return summary


def over_budget(segments, n, full_spheres, spec):
    """Why growing cannot pay (None if it can): the sphere steps run, plus the rest of the run
    with at least the current zone's spheres, reach zone_cost × the full model's."""
    full = full_spheres * spec.steps
    spent = sum(spheres * steps for spheres, steps in segments)
    rest = segments[-1][0] * (spec.steps - n)
    if not spec.zone_cost or spent + rest < spec.zone_cost * full:
        return None
    return (f"{spent:.4g} sphere steps run and at least {rest:.4g} to come reach zone.cost = "
            f"{spec.zone_cost:g} × the full model's {full:.4g}")
