"""One slab run, whatever its zone: the box zone's model (cases.slab.model), or the coupled
model's automatic zone search (cases.slab.search) or its zone grown during the run
(cases.slab.grow)."""
from cases.slab import model as fixed, search, timestep


def run(spec, model, out, quiet=False, resume=False, start=None, inputs=None):
    """cases.slab.model.run, or for a coupled model the search (zone "auto") or the
    growing zone (zone "grow", which resumes as a fixed zone does); with
    dt_safety "auto", the step chosen first (cases.slab.timestep)."""
    if spec.dt_safety == "auto":
        spec = timestep.choose(spec, model, log=(lambda line: None) if quiet else print)
    if spec.zone != "box" and model == "coupled":
        if spec.zone == "grow":
            from cases.slab.grow import run_grow
            return run_grow(spec, start() if start is not None else out, quiet, resume, inputs)
        if resume:
            raise ValueError(f"--resume: a run with zone {spec.zone!r} does not resume (its "
                             f"attempts start again from t = 0); run it again instead")
        return search.run_auto(spec, start() if start is not None else out, quiet)
    return fixed.run(spec, model, out, quiet, resume, start, inputs)
