"""Measures one slab model in its own process (peak memory and OMP_NUM_THREADS are per process).

Run by bench.run as `python -m bench.worker '<json task>'` with OMP_NUM_THREADS set; prints
one JSON line. Task keys: scale, model ("full" | "coupled"), warmup, steps, optionally spec
(the fields of a SlabSpec, instead of the scale's defaults) and zone_cells (a DE zone of
in-plane grid cells), impact_after_s (a second window of `steps` steps that starts this long
after the start, during the impact), and for the coupled model `variants` (coupling variants
to time, e.g. ["diagonal", "full"]) and `output` (time the run loop's output work); with
`conversion` (model "coupled"), instead: the default grown zone's cost of one conversion
(conversion_cost).
"""
import cProfile
import json
import math
import os
import pstats
import resource
import sys
import tempfile
from time import perf_counter, process_time

import numpy as np

clock = perf_counter  # set by use_clock


def timed_steps(m, warmup, steps):
    """Per-step time and time split (seconds, on `clock`) of `steps` steps after `warmup`;
    wall times alongside."""
    for _ in range(warmup):
        m.step()
    keys = list(m.seconds)
    times, wall, split = np.empty(steps), np.empty(steps), np.empty((steps, len(keys)))
    for n in range(steps):
        before = [m.seconds[k] for k in keys]
        c0, t0 = clock(), perf_counter()
        m.step()
        times[n], wall[n] = clock() - c0, perf_counter() - t0
        split[n] = [m.seconds[k] - b for k, b in zip(keys, before)]
    return {"clock": clock.__name__, "median_s": float(np.median(times)),
            "mean_s": float(times.mean()), "min_s": float(times.min()),
            "wall_median_s": float(np.median(wall)), "steps": steps, "warmup": warmup,
            "split_median_s": {k: float(np.median(split[:, i])) for i, k in enumerate(keys)},
            "split_mean_s": {k: float(split[:, i].mean()) for i, k in enumerate(keys)}}


def median_time(f, repeat):
    t = []
    for _ in range(repeat):
        t0 = clock()
        f()
        t.append(clock() - t0)
    return float(np.median(t))


def use_clock(threads):
    """With one thread, time in this process's CPU time, which other processes on a shared
    machine hardly change (wall time there counts their turns too); with more threads, wall
    time. The models' own time split (CoupledStepper, SlabModel) follows the same clock."""
    global clock
    clock = process_time if threads == 1 else perf_counter
    import orchestrator.builder
    import orchestrator.stepper
    for module in (orchestrator.builder, orchestrator.stepper):
        module.perf_counter = clock


def output_cost(m, repeat=3):
    """Output work of the run loop amortised per step: sensors and the quantities of interest
    (with their energy split's meter) every sample_every steps, energy check every
    check_every, a damage map, ParaView frame and the quantities' frame (the cracking energy
    and the energy split) every output_every; and apart, the meter's search for new contacts,
    which a sample adds while contacts are being made (cases.slab.energies.RELIST)."""
    from yade_side.output import SphereSeries
    spec = m.spec
    sensors = median_time(m.sensor_displacements, repeat)
    q = m.quantities()
    q.sample()                          # the energy split's meter starts at its first sample
    quantities = median_time(q.sample, repeat)
    search = median_time(q.energy.meter.relist, repeat)
    quantities_frame = median_time(q.output, repeat)
    energy = median_time(m.energy, repeat)
    with tempfile.TemporaryDirectory() as tmp:
        series = SphereSeries(os.path.join(tmp, "spheres.pvd"))
        fe_series = None
        if m.fe is not None:
            from fenicsx_side.output import XdmfSeries
            fe_series = XdmfSeries(os.path.join(tmp, "fe.xdmf"), m.fe)

        def frame():
            dmg = m.damage.update()
            m.slab.read()
            series.write(0.0, m.slab.pos, m.radius, displacement=m.slab.displacement(),
                         velocity=m.slab.vel, rotation_speed=m.slab.angvel, damage=dmg)
            if fe_series is not None:
                fe_series.write(0.0)

        frame_s = median_time(frame, repeat)
        if fe_series is not None:
            fe_series.close()
    per_step = ((sensors + quantities) / spec.sample_every + energy / spec.check_every
                + (frame_s + quantities_frame) / spec.output_every)
    return {"per_step_s": per_step, "sensors_s": sensors, "quantities_s": quantities,
            "quantities_frame_s": quantities_frame, "energy_search_s": search,
            "energy_s": energy, "frame_s": frame_s,
            "every": [spec.sample_every, spec.check_every, spec.output_every]}


def coupling_parts(m, repeat=20):
    """Median cost of the pieces of the coupling step, from the state of the last step
    (restored afterwards)."""
    st = m.stepper
    b, c = st.bridge, st.last
    dt = st.dt
    state, rotation = b.read().copy(), b.rotation.copy()
    d, w = b.displacement(), b.rotation_pred.copy()
    parts = {
        "read_s": median_time(b.read, repeat),
        "multipliers_s": median_time(lambda: st.coupling.correct(d, w, st.fe.u), repeat),
        "correct_and_write_spheres_s": median_time(lambda: b.correct(c.dd, c.dw, dt), repeat),
        "write_s": median_time(b.write, repeat),
        "correct_fe_s": median_time(lambda: st.fe.correct(c.fe_dofs, 0 * c.du, dt), repeat),
        "exchange_meter_s": median_time(lambda: st.exchange.update(c), repeat),
        "direct_memory_exchange": b.direct,
    }
    from yade_side.bulk import BodySet
    api = BodySet(b.ids, direct=False)  # YADE's own bulk API, for comparison
    api.state[:] = state
    parts["api_read_s"] = median_time(api.read, repeat)
    parts["api_write_s"] = median_time(api.write, repeat)
    b.state[:] = state
    b.write()
    b.rotation[:] = rotation
    return parts


# the task's keys: those it must have, and the others it may have
TASK_NEEDS = ("model", "warmup", "steps")
TASK_MAY = ("scale", "spec", "zone_cells", "impact_after_s", "variants", "output", "conversion",
            "profile")
MODELS = ("full", "coupled")


def check_task(task):
    """Refuse a task the worker cannot run, in one line naming the key: not an object, a
    key it does not know, one it needs missing, a model or a spec field that does not exist.
    The values themselves are SlabSpec's to check, as a run does."""
    from dataclasses import fields
    from cases.slab.spec import SlabSpec
    if not isinstance(task, dict):
        raise ValueError(f"bench.worker: the task must be a JSON object, got {task!r}")
    unknown = sorted(set(task) - set(TASK_NEEDS) - set(TASK_MAY))
    missing = [k for k in TASK_NEEDS if k not in task]
    if "scale" not in task and "spec" not in task:
        missing.append("scale (or spec)")
    if unknown or missing:
        raise ValueError("bench.worker: " + "; ".join(
            ([f"unknown key(s) {', '.join(unknown)} (it knows "
              f"{', '.join(TASK_NEEDS + TASK_MAY)})"] if unknown else [])
            + ([f"missing {', '.join(missing)}"] if missing else [])))
    if task["model"] not in MODELS:
        raise ValueError(f"bench.worker: model = {task['model']!r}: one of {', '.join(MODELS)}")
    spec = task.get("spec", {})
    if not isinstance(spec, dict):
        raise ValueError(f"bench.worker: spec must be an object of SlabSpec fields, got {spec!r}")
    known = {f.name for f in fields(SlabSpec)}
    if set(spec) - known:
        raise ValueError(f"bench.worker: spec: no SlabSpec field "
                         f"{', '.join(sorted(set(spec) - known))}")


def run(task):
    from cases.slab import SlabModel, SlabSpec
    from yade_side import import_yade
    threads = int(os.environ.get("OMP_NUM_THREADS", "1"))
    import_yade(threads=threads)
    use_clock(threads)
    if task.get("conversion"):
        return conversion_cost(task)
    spec = SlabSpec(**task["spec"]) if "spec" in task else SlabSpec(scale=task["scale"])
    t0 = perf_counter()
    m = SlabModel(spec, task["model"], _zone(spec, task.get("zone_cells")))
    result = {"task": task, "build_s": perf_counter() - t0, "n_spheres": m.sphere_count(),
              "n_bridging_spheres": len(m.bridge_index),
              "n_fe_nodes": 0 if m.fe is None else len(m.fe.nodes), "dt": m.dt,
              "dt_safety": spec.dt_safety}
    result["timing"] = timed_steps(m, task["warmup"], task["steps"])
    if task.get("output"):
        result["output"] = output_cost(m)
    if task.get("impact_after_s"):
        # the busiest part of a run: contacts, damage, link deletion, impact_after_s after
        # the start (the impactor touches the slab within 0.1 ms)
        advance = max(0, math.ceil(task["impact_after_s"] / m.dt) - task["warmup"] - task["steps"])
        result["timing_impact"] = timed_steps(m, advance, task["steps"])
    # the run's peak: before the coupling pieces and the other variant are timed
    result["peak_rss_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    if m.stepper is not None:
        result["variant"] = spec.variant
        result["coupling_parts"] = coupling_parts(m)
        result["variants"] = {spec.variant: _variant_summary(m, result["timing"])}
        for variant in task.get("variants", []):
            if variant != spec.variant:
                result["variants"][variant] = _time_variant(m, variant, task)
    result["peak_rss_end_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return result


# the impactor's fall before contact in the conversion's timing (0.5 ms at 40 m/s: longer
# than its steps): no indicator trips, so the steps timed are those of the model it made
CONVERSION_GAP = 0.02


def conversion_cost(task):
    """One conversion of the default zone grown during the run (cases.slab.grow), its start
    zone and the margin's ring of cells around it, `warmup` steps into the run, timed on the
    clock and against the median step of the grown model (`steps` steps after it): the
    conversion's cost in steps of the model it makes. The impactor falls CONVERSION_GAP
    first: what a conversion costs does not depend on the damage. With "profile": true, the
    conversion's profile (cProfile, by cumulative time) goes to stderr, its time with it."""
    from cases.slab import SlabSpec
    from cases.slab.grow import growing_model
    from orchestrator.run.autozone import Tripped
    spec = SlabSpec(**task.get("spec", {"scale": task["scale"]}), impactor_gap=CONVERSION_GAP)
    m, _ = growing_model(spec, log=lambda line: None)
    for _ in range(task["warmup"]):
        m.step()
    before = m.sphere_count()
    profile = cProfile.Profile() if task.get("profile") else None
    c0 = clock()
    if profile:
        profile.enable()
    m.grow(Tripped(m.steps, "bench: the start zone's ring", m.zone.copy()))
    if profile:
        profile.disable()
        pstats.Stats(profile, stream=sys.stderr).sort_stats("cumulative").print_stats(40)
    seconds = clock() - c0
    record, after = m.conversions[-1], m.sphere_count()
    timing = timed_steps(m, 2, task["steps"])
    if len(m.conversions) > 1:
        raise RuntimeError("the zone grew again while its steps were timed")
    return {"task": task, "start_zone_m": spec.de_zone if spec.zone_start is None
            else spec.zone_start, "spheres_before": before, "spheres_after": after,
            "conversion_s": seconds, "build_wall_s": record["build_s"],
            "carry_wall_s": record["carry_s"],
            "wall_s": record["wall_s"], "grown_step_s": timing["median_s"],
            "conversion_steps": seconds / timing["median_s"],
            "peak_rss_bytes": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
            "timing": timing, "checks": _bounded_checks(m)}


def _bounded_checks(m):
    """The grown model's stability checks as the conversion made them (bounds, where they
    held) beside the exact values they stand for, found here, after the timing: the FE's
    critical step and the lumping ratio ρ (r must be at least ρ/2)."""
    from orchestrator.coupling.multipliers import lumping_ratio
    c = m.stepper.coupling
    return {"dt": m.dt, "critical_dt": m.critical, "fe_critical_dt_exact": m.fe.critical_dt(),
            "relaxation": c.relaxation, "lumping_ratio_bound": c.lumping_bound,
            "lumping_ratio_exact": lumping_ratio(c.G, c.de_inv_mass, c.fe_inv_mass, c.dt,
                                                 c.solver.diagonal)}


def _zone(spec, cells):
    """The slab grid with a DE zone of in-plane cells (an automatic zone's final one), or
    None: the spec's box."""
    if cells is None:
        return None
    from cases.slab.zone import cells_grid
    return cells_grid(spec, cells)


def _variant_summary(m, timing):
    return {"coupling_s": timing["split_median_s"]["coupling"],
            "guarded_rows": m.stepper.coupling.solver.guarded_rows}


def _time_variant(m, variant, task):
    """Swap the coupling for another variant and time it; for the full variant also time the
    set-up (assembly of T and its sparse Cholesky factorisation)."""
    from dataclasses import replace
    from orchestrator.builder import CouplingSpec, couple
    from orchestrator.coupling.multipliers import FullSolver
    spec = m.spec
    t0 = perf_counter()
    coupling, _, _ = couple(m.fe, m.bridging, m.bridge, m.dt, replace(CouplingSpec(
        spec.variant, spec.relaxation, spec.rotations, spec.weighting), variant=variant),
        m.critical)
    out = {"coupling_setup_s": perf_counter() - t0}
    if variant == "full":
        c = coupling
        out["factorisation_s"] = median_time(
            lambda: FullSolver(c.G, c.de_inv_mass, c.fe_inv_mass, c.dt), 3)
        out["backend"] = c.solver.backend
        out["system_size"] = int(np.count_nonzero(c.fe_inv_mass))
    m.swap_coupling(coupling)
    timing = timed_steps(m, max(2, task["warmup"] // 4), max(10, task["steps"] // 2))
    out.update(_variant_summary(m, timing))
    out["step_median_s"] = timing["median_s"]
    return out


def main(argv):
    """One JSON line of results, or one line saying what is wrong with the task (exit 2)."""
    try:
        if len(argv) != 1:
            raise ValueError("bench.worker: give one task, a JSON object (see this module's "
                             "docstring)")
        try:
            task = json.loads(argv[0])
        except ValueError as e:
            raise ValueError(f"bench.worker: the task is not JSON ({e})") from None
        check_task(task)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(json.dumps(run(task)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
