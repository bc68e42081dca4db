"""The automatic zone's search (`--zone auto`): attempts of the coupled slab grown by the
run's own checks (orchestrator.run.autozone), each from t = 0, until one runs clean or
the zone would pass its limit or its budget.

Results folder: attempt-K/ holds each tripped attempt (run.log and what it wrote before its
trip); the last attempt's results are the folder's own, with summary.json recording the
search and zones.png the zones grown over the slab's plan.
"""
from dataclasses import asdict, replace

from cases.slab.model import SlabModel, run, run_built
from cases.slab.zone import cell_grid, check, zone_grid
from common.files import write_json
from orchestrator.run.autozone import find_zone, plot_zones


def run_auto(spec, out, quiet=False):
    """Attempts of the coupled slab until one runs clean or the zone would pass its limit
    (then the full model with fallback = "full"); returns the summary written in `out`."""
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
        summary = fallback(spec, out, quiet)
    summary.update(record)
    write_json(out / "summary.json", summary)
    plot_zones(out / "zones.png", grid, outcome, limit, f"slab {spec.scale}, "
               f"{spec.impactor_speed:g} m/s")
    return summary


def fallback(spec, out, quiet, resume=False):
    """When coupling cannot pay: the full model's run in `out` with fallback "full" (its
    summary; resume: carry it on from its checkpoint in out/full), else a summary that says
    only what was asked."""
    if spec.fallback != "full":
        return {"model": "coupled", "spec": asdict(spec)}
    full_out = out / "full"
    if not resume:
        full_out.mkdir()
    summary = run(replace(spec, zone="box"), "full", full_out, quiet, resume=resume)
    for entry in list(full_out.iterdir()):
        entry.rename(out / entry.name)
    full_out.rmdir()
    summary["zone_fallback"] = "full"
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


def cannot_pay(detail):
    """The one line of a zone that cannot grow enough (searched or grown during the run)."""
    return f"coupling cannot pay for this impact, because what the DE zone must hold " \
           f"spreads too far: {detail}"


def message(outcome, full_spheres, record):
    """The search's one line: that coupling cannot pay, and because of what (the concrete the
    DE zone must hold spreads past the zone's limit or its budget: the last trip says where)."""
    a = outcome.attempts[-1]
    why = (f"would pass its limit ({a['beyond_limit']})" if outcome.limit == "cells" else
           "would cost more than the full model (zone.cost) in another attempt")
    return cannot_pay(f"after {len(outcome.attempts)} attempts, the last tripped at step "
            f"{a['tripped_step']} by {a['indicator']}, the DE zone ({a['cells']} of "
            f"{outcome.zone.size} in-plane cells, {a['spheres']} of the full model's "
            f"{full_spheres} spheres) {why}; {outcome.wall_s:.3g} s spent against a projected "
            f"{record['full_model_projected']['wall_s']:.3g} s for the full model")
