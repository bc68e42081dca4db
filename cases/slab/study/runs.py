"""Running the study's plan (cases.slab.study.plan): each run an ordinary slab run in its
folder, skipped when done with the same description (here or in a reused ensemble), so that
the study resumes after an interruption. The full members of an impact run after its coupled
runs and carry the sensors of each coupled zone (cases.slab.probes), the automatic zones'
final zones included."""
from dataclasses import dataclass
from pathlib import Path

from cases.slab.study.plan import complete, where
from cases.slab.probes import full_names
from cases.slab.study.table import layout_label


@dataclass
class Outcome:
    folder: Path
    summary: dict       # None: not run (skipped or failed)
    status: str         # "done", "reused", "ran", "skipped: ...", "failed: ..."


def layout(run, summary):
    """(spec, grid) of the zone of the coupled `run` (summary: its finished run's, for the
    automatic zone's final cells), or None when it ended at its limit."""
    from cases.slab.zone import cells_grid, slab_grid
    spec = run.spec()
    if run.config.zone != "auto":
        return spec, slab_grid(spec)
    if summary is None or summary.get("zone_outcome") != "clean":
        return None
    return spec, cells_grid(spec, summary["zone_final"]["cells"])


def probes_needed(group_runs, outcomes):
    """{label: (spec, grid)} of the coupled zones of one impact whose sensors the full members
    must carry."""
    out = {}
    for r in group_runs:
        if r.config.model == "full":
            continue
        label = layout_label(r)
        if label is None or label in out:
            continue
        o = outcomes.get(r.folder)
        zone = layout(r, None if o is None else o.summary)     # a box: whatever its run did
        if zone is not None:
            out[label] = zone
    return out


def missing_probes(summary, labels):
    names = set(summary.get("sensors", {}))
    return [label for label in labels
            if not set(full_names(label, ["de_zone", "bridging", "fe_node"])) <= names]


def execute(runs, out, index, quiet=False, log=print, dry=False):
    """Run the planned `runs` not done yet, in order; {run folder: Outcome}. With `dry`, only
    what would happen. A run that fails is marked FAILED in its folder and the study goes on."""
    from orchestrator.run.folder import settle_failure
    from orchestrator.run.guard import BlowUp
    from orchestrator.run.loop import StepFailed
    outcomes = {}
    for k, r in enumerate(runs):
        tag = f"[{k + 1}/{len(runs)}] {r.folder}"
        if r.when is not None:
            dep = outcomes.get(r.when)
            if dep is None or dep.summary is None or dep.summary.get("zone_outcome") != "clean":
                outcomes[r.folder] = Outcome(Path(out) / r.folder, None,
                                             f"skipped: {r.when} did not end clean")
                log(f"{tag}: {outcomes[r.folder].status}")
                continue
        folder, summary = where(r, out, index)
        layouts = {}
        if r.config.model == "full":
            same = [x for x in runs if x.config.group == r.config.group]
            layouts = probes_needed(same, outcomes)
            if summary is not None and missing_probes(summary, layouts):
                folder, summary = Path(out) / r.folder, None
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
            summary = run_one(r, folder, layouts, quiet, log)
            outcomes[r.folder] = Outcome(Path(folder), summary, "ran")
        except (ValueError, BlowUp, StepFailed) as e:      # bad input or a run gone wrong
            settle_failure(f"error: {e}")
            outcomes[r.folder] = Outcome(Path(folder), None, f"failed: {e}")
            log(f"{tag}: failed: {e}")
    return outcomes


def run_one(r, folder, layouts, quiet, log=print):
    """One planned run into `folder`: carried on from the checkpoint an interrupted study left
    there (a fixed zone or a full run with the same probes), else from the start (an
    unfinished study folder there is replaced)."""
    from cases.slab.runs import run
    from cases.slab.probes import run_full
    from orchestrator.run.folder import forget, prepare_out, resume_folder
    from orchestrator.run.restart import read_meta
    spec = r.spec()
    resume = r.config.zone != "auto"
    try:
        read_meta(folder)
    except ValueError:                  # no checkpoint there
        resume = False
    for carry_on in ([True, False] if resume else [False]):
        start = None if carry_on else (lambda: prepare_out(folder, force=True))
        if carry_on:
            resume_folder(folder)
        try:
            if r.config.model == "full":
                summary = run_full(spec, layouts, folder, quiet, start=start, resume=carry_on)
            else:
                summary = run(spec, "coupled", folder, quiet, resume=carry_on, start=start)
            break
        except ValueError as e:
            if not carry_on:
                raise
            log(f"{folder}: its checkpoint is of another run ({e}); starting again")
    forget()
    if complete(folder, r) is None:
        raise ValueError(f"{folder}: the run ended without its results")
    return summary
