"""The slab's DE zone grown during the run (`--zone grow`, orchestrator.run.grow): the same
start zone, limit, trip levels and budget as `--zone auto` (cases.slab.zone), but a trip
converts the flagged cells and the run goes on from the same step.

Results folder: the run's results as any slab run's, the FE series in fe.xdmf and then one
file per zone (fe-zone2.xdmf, …); summary.json records each conversion (`zone_conversions`)
and zones.png the zone's growth over the slab's plan. When the zone cannot grow further (its
limit, or the budget), one line says that coupling cannot pay for this impact; what the run
wrote until then is kept in stopped/, and with fallback "full" the full model runs in the
folder.

Checkpoints and `--resume` (docs/auto-zone.md): a checkpoint holds, beside what a fixed
zone's holds (scene, FE, coupling, the run's record), the growth
(orchestrator.run.grow.GrowingModel.checkpoint_state); a resumed run builds the model of the
zone the checkpoint was in, with the run's time step, and the run loop loads the state into
it.
"""
from dataclasses import asdict
from pathlib import Path
from time import perf_counter
from types import SimpleNamespace

import numpy as np

from cases.slab.model import SlabModel, run_built
from cases.slab.search import cannot_pay, fallback
from cases.slab.zone import cell_grid, check, slab_bridging, zone_grid
from common.files import write_json
from orchestrator.run.autozone import plot_zones
from orchestrator.run.grow import GrowingModel, ZoneLimit


def growing_model(spec, resumed=None, log=print):
    """The GrowingModel of `spec`'s zone grown during the run, its first model built (with
    `resumed`, a checkpoint's growth, the model of its last zone), and the full model's
    spheres (slab and impactor), against which its budget counts."""
    base, start, limit, levels = check(spec)
    dt = None if resumed is None else float(resumed.info["dt"])   # every zone: the first's
    packs = None                                                   # and its packings

    def build(mask, grown_from=None, earlier=()):
        nonlocal dt, packs
        keeps = [slab_bridging(spec, zone_grid(base, m)).covers for m in earlier]
        m = SlabModel(spec, "coupled", zone_grid(base, mask), dt, packs, grown_from, keeps)
        dt, packs = m.dt, m.scene.packs
        return m

    model = GrowingModel(build, cell_grid(base), start, limit, spec.tensile_strength, levels,
                         tol=1e-6 * spec.radius, log=log, shear=spec.grow_shear,
                         budget=lambda segments, n: over_budget(segments, n, full_spheres,
                                                                spec),
                         resumed=resumed, last_step=spec.steps)
    full_spheres = len(model.scene.packs.slab_radii) + len(model.impactor_ids)
    return model, full_spheres


def run_grow(spec, out, quiet=False, resume=False, inputs=None):
    """The coupled slab with a zone grown during the run; returns the summary written in
    `out`; resume: carry on from the checkpoint in `out` (`inputs`: what the results depend
    on, orchestrator.run.inputs; a resumed run must have the same), or, when the zone had
    reached its limit, the fallback's full model from its own (fallback_growth)."""
    from orchestrator.run.inputs import spec_inputs
    started = perf_counter()
    base, start, limit, _ = check(spec)
    grid = cell_grid(base)
    inputs = spec_inputs(spec, "coupled") if inputs is None else inputs
    growth = fallback_growth(out) if resume else None
    if growth is not None:
        return _limit_summary(spec, out, grid, limit, growth, fallback(spec, out, quiet, True))
    resumed = resumed_growth(out, inputs, grid, start, limit) if resume else None
    model, full_spheres = growing_model(spec, resumed, (lambda line: None) if quiet else print)
    try:
        summary = run_built(model, out, quiet, resume, inputs)
    except ZoneLimit as e:
        stopped = out / "stopped"
        stopped.mkdir()
        for entry in list(out.iterdir()):
            if entry != stopped and not entry.name.startswith("."):    # the folder's marker
                entry.rename(stopped / entry.name)
        message = cannot_pay(
            f"after {len(model.conversions)} conversions during the run, at step "
            f"{e.tripped.step} ({e.tripped.indicator}), {e.reason} (DE zone "
            f"{int(model.zone.sum())} of {model.zone.size} in-plane cells, "
            f"{model.sphere_count()} of the full model's {full_spheres} spheres)")
        print(message)
        # the wall time to the limit, build included (a resumed run: since its resume)
        growth = {**_growth_record(spec, model, full_spheres), "zone_outcome": "limit",
                  "zone_wall_s": perf_counter() - started,
                  "zone_limit_reached": e.reached, "zone_message": message,
                  "zones": np.array(model.zones).tolist()}
        write_json(stopped / GROWTH, {"spec": asdict(spec), **growth})
        return _limit_summary(spec, out, grid, limit, growth, fallback(spec, out, quiet))
    summary.update(_growth_record(spec, model, full_spheres), zone_outcome="clean",
                   zone_limit_reached=None, n_slab_spheres=len(model.slab_ids),
                   zone_cells=np.argwhere(model.zone).tolist())
    return _write_summary(spec, out, grid, limit, summary, model.zones)


# what a run stopped at its limit keeps of its growth, in stopped/, for its summary: written
# before the fallback runs, read back when that is resumed
GROWTH = "growth.json"


def fallback_growth(out):
    """The growth record (stopped/growth.json: the spec, as a dict, and what the summary
    takes) of the grown run in `out` whose zone reached its limit, if its fallback's full
    model was stopped (out/full is there); else None."""
    import json
    out = Path(out)
    path = out / "stopped" / GROWTH
    if not (path.is_file() and (out / "full").is_dir()):
        return None
    try:
        growth = json.loads(path.read_text())
        growth["spec"], growth["zones"]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{path}: unreadable ({e!r}): run it again") from None
    return growth


def fallback_spec(out):
    """The spec of the grown run in `out` whose fallback can be resumed (fallback_growth), or
    None."""
    from cases.slab.spec import SlabSpec
    growth = fallback_growth(out)
    return None if growth is None else SlabSpec(**growth["spec"])


def _growth_record(spec, model, full_spheres):
    """What summary.json records of the growth and its cost against the full model."""
    return {**model.record(spec.steps), "zone_full_model_spheres": full_spheres,
            "zone_full_model_sphere_steps": full_spheres * spec.steps}


def _limit_summary(spec, out, grid, limit, growth, summary):
    """The summary of a run whose zone reached its limit: its fallback's `summary` and the
    growth record (`growth`, with its zones, and its spec, left out)."""
    growth = {k: v for k, v in growth.items() if k != "spec"}
    zones = [np.array(z, dtype=bool) for z in growth.pop("zones")]
    return _write_summary(spec, out, grid, limit, {**summary, **growth}, zones)


def _write_summary(spec, out, grid, limit, summary, zones):
    summary["zone_final"]["grid"] = {"p0": grid.p0.tolist(), "p1": grid.p1.tolist(),
                                     "n": grid.n.tolist(), "axes": grid.axes}
    write_json(out / "summary.json", summary)
    plot_zones(out / "zones.png", grid, SimpleNamespace(zones=zones,
                                                        status=summary["zone_outcome"]),
               limit, f"slab {spec.scale}, {spec.impactor_speed:g} m/s, grown during the run",
               joined="zone the cell joined (1: the start)")
    return summary


def resumed_growth(out, inputs, grid, start, limit):
    """The growth kept in the checkpoint in `out` (orchestrator.run.grow.ResumedGrowth),
    checked against this run's case before any model is built: ValueError (one line) if the
    case changed since (each difference named) or the growth does not fit its grid, start
    zone and limit."""
    from orchestrator.run.grow import GROWTH_STATE_VERSION, ResumedGrowth
    from orchestrator.run.restart import check_inputs, model_state
    if (out / "stopped").exists():
        raise ValueError(f"{out}: its zone reached its limit and what it ran is in stopped/; "
                         f"nothing of the growing run to resume")
    check_inputs(out, inputs)
    info, arrays = model_state(out)
    where = f"{out}/checkpoint: the zone growth it holds"
    version = info.get("version") if isinstance(info, dict) else None
    if version != GROWTH_STATE_VERSION or "zones" not in arrays:
        raise ValueError(f"{where} is not one this version reads (version {version!r}, "
                         f"{GROWTH_STATE_VERSION} here): run it again")
    zones = np.asarray(arrays["zones"])
    try:
        dt = float(info["dt"])
        conversions, segments = info["conversions"], info["segments"]
        info["peaks"], info["watch"]["steps"], info["sensors"]
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{where} is unreadable ({e!r} missing or wrong)") from None
    why = (f"its zones are masks of shape {zones.shape[1:]}, the case's grid has {grid.shape}"
           if zones.ndim != 3 or zones.dtype != bool or zones.shape[1:] != tuple(grid.shape)
           else "its first zone is not the case's start zone"
           if not np.array_equal(zones[0], start)
           else "a zone passes the case's limit" if (zones & ~limit).any()
           else "a zone does not hold the one before" if (zones[:-1] & ~zones[1:]).any()
           else f"{len(zones)} zones for {len(conversions)} conversions"
           if len(zones) != len(conversions) + 1 or len(segments) != len(conversions)
           else f"its time step {dt!r} is not a positive number" if not (dt > 0)
           else None)
    if why:
        raise ValueError(f"{where} does not fit the case ({why}): run it again with --out")
    return ResumedGrowth(info, arrays)


# What a conversion (the grown model's build and the state carried into it) costs, as the
# budget counts it, in sphere steps: a fixed part, CONVERSION_STEPS steps of the first grown
# zone (the FE part and the band made anew are as large at every conversion; the first
# conversion at each scale cost 45-56 steps of its zone, `make bench`, rounded up; 35-46
# since, kept so that the trip levels' table, docs/auto-zone.md, stands), plus
# CONVERSION_GROWTH steps of the zone it makes (what grows with the zone: its spheres' weights,
# sets and depths; 1.6 steps at medium scale and 5.9 at paper scale in the runs' conversions,
# docs/auto-zone.md, "What a conversion costs")
CONVERSION_STEPS = 60
CONVERSION_GROWTH = 6


def conversion_cost(first, spheres):
    """Sphere steps the budget counts for a conversion to a zone of `spheres`, the first
    conversion's zone having `first`."""
    return CONVERSION_STEPS * first + CONVERSION_GROWTH * spheres


def over_budget(segments, n, full_spheres, spec):
    """Why growing at step n cannot pay (None if it can): the sphere steps run (each
    conversion counted by conversion_cost), plus the conversion asked for and the rest of the
    run with at least the current zone's spheres, reach zone_cost × the full model's.
    segments: (spheres, steps) of each zone so far."""
    full = full_spheres * spec.steps
    current = segments[-1][0]
    first = segments[1][0] if len(segments) > 1 else current
    spent = sum(spheres * steps for spheres, steps in segments) + \
        sum(conversion_cost(first, spheres) for spheres, _ in segments[1:])
    rest = conversion_cost(first, current) + current * (spec.steps - n)
    if not spec.zone_cost or spent + rest < spec.zone_cost * full:
        return None
    return (f"{spent:.4g} sphere steps run (each conversion counted as {CONVERSION_STEPS} "
            f"steps of the first grown zone and {CONVERSION_GROWTH} of its own) and at least "
            f"{rest:.4g} to come reach zone.cost = {spec.zone_cost:g} × "
            f"the full model's {full:.4g}")
