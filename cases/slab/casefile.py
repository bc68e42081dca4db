"""Slab case files (`kind = "slab"`): the keys are SlabSpec's fields (their tables in
SlabSpec's metadata), plus slab.model."""
from cases.slab.model import MODELS, run as run_model
from cases.slab.spec import SlabSpec
from orchestrator.casefile import CASE, REQUIRED, Key, choice, spec_from_case, spec_schema

SCHEMA = {"case": CASE, **spec_schema(SlabSpec)}
# no default model, as for the `slab` command: full or coupled is the user's choice
SCHEMA["slab"] = {"model": Key(choice(*MODELS), REQUIRED), **SCHEMA["slab"]}


def spec(case):
    """The SlabSpec of a slab case (keys left out keep SlabSpec's defaults)."""
    return spec_from_case(SlabSpec, case.data)


def run(case, out, force=False, quiet=False, resume=False):
    from orchestrator.run.folder import start_folder
    start = None if resume else (lambda: start_folder(case, out, force))
    return run_model(spec(case), case["slab"]["model"], out, quiet=quiet, resume=resume,
                     start=start)
