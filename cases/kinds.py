"""The kinds of case a case file can describe, with their schemas and runners."""
from cases import generic
from cases.slab import casefile as slab_case
from cases.wave1d import casefile as wave1d_case
from orchestrator.casefile import Kind, load

KINDS = {"generic": Kind(generic.SCHEMA, generic.check),
         "slab": Kind(slab_case.SCHEMA, slab_case.check),
         "wave1d": Kind(wave1d_case.SCHEMA)}
RUNNERS = {"generic": generic.run, "slab": slab_case.run, "wave1d": wave1d_case.run}


def case_inputs(case):
    """What a case's results depend on (orchestrator.run.inputs): a resumed run compares it
    with its checkpoint's."""
    from orchestrator.run import inputs
    if case.kind == "slab":
        return inputs.spec_inputs(slab_case.spec(case), case["slab"]["model"])
    return inputs.case_inputs(case)


def load_case(path, overrides=()):
    """A checked case file of any kind (orchestrator.casefile.load)."""
    return load(path, KINDS, overrides)


def run_case(case, out, force=False, quiet=False, threads=None, resume=False):
    """Build and run a checked case into the results folder `out`; returns the summary.
    The folder gets `case.toml`: the case as run (defaults filled in, --set applied, paths
    absolute), which runs again as it is. resume: carry on from the checkpoint in `out`
    (which holds that case.toml)."""
    from yade_side import import_yade
    import_yade(threads)
    return RUNNERS[case.kind](case, out, force=force, quiet=quiet, resume=resume)
