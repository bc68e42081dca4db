"""The per-step cost of each model of the study "where coupling pays", timed as `make bench`
times: each model built in a fresh process (bench.worker) from its run's recorded description,
one after the other, a short window in the process's CPU time, which other jobs on a shared
core hardly change. Separate runs' wall times gave 0.46-2.57 for the same pair of models on
the loaded machine; this costs a few percent of the study.

Window: at medium scale TIMING_AFTER_CONTACT_S into the impact (contacts, damage, link
deletion: the bulk of a run); at paper scale right after the build (the impact window would
need ~700 steps of the full model first: 7 minutes)."""
import subprocess

from bench.report import model_figures
from bench.run import worker
from cases.slab.study.plan import TIMING_STEPS, advance_steps, timed
from common.files import write_json


def task(run, summary):
    """The bench.worker task that times the model of the finished `run`."""
    spec = summary["spec"]
    warmup, steps = TIMING_STEPS
    t = {"scale": spec["scale"], "model": run.config.model, "spec": spec, "warmup": warmup,
         "steps": steps, "output": True}
    if run.config.model == "coupled" and run.config.zone != "box":    # its final zone
        t["zone_cells"] = summary["zone_final"]["cells"]
    n = advance_steps(run.spec(), summary["dt"])
    if n:
        t["impact_after_s"] = (n + warmup + steps) * summary["dt"]
    return t


def time_models(runs, outcomes, path, previous=None, log=print):
    """{run folder: figures} of the first seed of every configuration whose run finished
    (a grown zone: only one that ended clean); the entries of `previous` (an earlier
    timing.json) are kept, and reused when their task is the same. Written to `path` after
    each model."""
    previous = dict(previous or {})
    out = dict(previous)
    for r in timed(runs):
        o = outcomes.get(r.folder)
        if (o is None or o.summary is None or "n_spheres" not in o.summary
                or o.summary.get("zone_outcome") == "limit"):
            continue
        t = task(r, o.summary)
        if previous.get(r.folder, {}).get("task") == t:
            out[r.folder] = previous[r.folder]
            continue
        log(f"timing {r.folder} ...")
        try:
            result = worker(t)
        except (RuntimeError, subprocess.TimeoutExpired) as e:
            log(f"timing {r.folder} failed (its speed-up falls back to the runs'): "
                f"{str(e).splitlines()[0]}")
            continue
        f = model_figures(result)
        out[r.folder] = {"task": t, "step_s": f["impact_step_s"] or f["step_s"],
                         "window": "impact" if f["impact_step_s"] else "after the build",
                         "n_spheres": f["n_spheres"], "clock": result["timing"]["clock"],
                         "split_s": f["split_s"]}
        write_json(path, out)
    write_json(path, out)
    return out
