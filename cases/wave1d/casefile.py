"""wave1d case files (`kind = "wave1d"`): the keys are Wave1DSpec's fields (the `wave1d`
command's options)."""
from cases.wave1d.model import result_line, run_to_folder
from cases.wave1d.spec import Wave1DSpec
from orchestrator.casefile import CASE, spec_from_case, spec_schema

SCHEMA = {"case": CASE, **spec_schema(Wave1DSpec)}


def run(case, out, force=False, quiet=False, resume=False):
    from orchestrator.run.folder import start_folder
    if resume:
        raise ValueError("a wave1d case is short and has no checkpoints: run it again")
    spec = spec_from_case(Wave1DSpec, case.data)
    out = start_folder(case, out, force)
    summary = run_to_folder(spec, out)
    print(result_line(spec, summary, out))
    return summary
