"""Running the study's plan (cases.slab.study.plan): each run an ordinary slab run in its
folder, skipped when done with the same description (here or in a reused ensemble), so that
the study resumes after an interruption. The yardstick judges on the quantities of interest,
which do not depend on the coupled model's zone: one full ensemble serves every zone of its
impact."""
from dataclasses import dataclass
from pathlib import Path

from cases.slab.study.plan import complete, where


@dataclass
class Outcome:
    folder: Path
    summary: dict       # None: not run (failed, or a dry run)
    status: str         # "done", "reused", "ran", "to run", "failed: ..."


def execute(runs, out, index, quiet=False, log=print, dry=False):
    """Run the planned `runs` not done yet, in order; {run folder: Outcome}. With `dry`, only
    what would happen. A run that fails is marked FAILED in its folder and the study goes on."""
    from orchestrator.run.folder import settle_failure
    from orchestrator.run.guard import BlowUp
    from orchestrator.run.loop import StepFailed
    outcomes = {}
    for k, r in enumerate(runs):
        tag = f"[{k + 1}/{len(runs)}] {r.folder}"
        folder, summary = where(r, out, index)
        if summary is not None:
            status = "done" if Path(folder) == Path(out) / r.folder else "reused"
            outcomes[r.folder] = Outcome(Path(folder), summary, status)
            log(f"{tag}: {status} ({folder})")
            continue
        if dry:
            outcomes[r.folder] = Outcome(Path(folder), None, "to run")
            continue
        log(f"{tag}: running")
        try:
            outcomes[r.folder] = Outcome(Path(folder), run_one(r, folder, quiet, log), "ran")
        except (ValueError, BlowUp, StepFailed) as e:      # bad input or a run gone wrong
            settle_failure(f"error: {e}")
            outcomes[r.folder] = Outcome(Path(folder), None, f"failed: {e}")
            log(f"{tag}: failed: {e}")
    return outcomes


def run_one(r, folder, quiet, log=print):
    """One planned run into `folder`: carried on from the checkpoint an interrupted study left
    there, else from the start (an unfinished study folder there is replaced)."""
    from cases.slab.runs import run
    from orchestrator.run.folder import forget, prepare_out, resume_folder
    from orchestrator.run.restart import read_meta
    spec = r.spec()
    try:
        read_meta(folder)
        resume = True
    except ValueError:                  # no checkpoint there
        resume = False
    for carry_on in ([True, False] if resume else [False]):
        start = None if carry_on else (lambda: prepare_out(folder, force=True))
        if carry_on:
            resume_folder(folder)
        try:
            summary = run(spec, r.config.model, folder, quiet, resume=carry_on, start=start)
            break
        except ValueError as e:
            if not carry_on:
                raise
            log(f"{folder}: its checkpoint is of another run ({e}); starting again")
    forget()
    if complete(folder, r) is None:
        raise ValueError(f"{folder}: the run ended without its results")
    return summary
