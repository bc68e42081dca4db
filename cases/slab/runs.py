"""One slab run, whatever its zone: the box zone's model (cases.slab.model), or the coupled
model's automatic zone search (cases.slab.search)."""
from cases.slab import model as fixed, search, timestep


def run(spec, model, out, quiet=False, resume=False, start=None, inputs=None):
    """cases.slab.model.run, or the search for a coupled model with zone "auto"; with
    dt_safety "auto", the step chosen first (cases.slab.timestep)."""
    if spec.dt_safety == "auto":
        spec = timestep.choose(spec, model, log=(lambda line: None) if quiet else print)
    if spec.zone == "auto" and model == "coupled":
        if resume:
            raise ValueError("--resume: an auto-zone run restarts its attempts from t = 0; "
                             "run it again instead")
        return search.run_auto(spec, start() if start is not None else out, quiet)
    return fixed.run(spec, model, out, quiet, resume, start, inputs)
