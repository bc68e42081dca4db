"""Batches on a Slurm cluster: `batch --slurm` writes a job-array script, one array task per
run; each task runs `batch ... --task $SLURM_ARRAY_TASK_ID`, i.e. its one run, and rewrites
`batch_summary.csv` from the rows of the tasks finished so far (each task's row is kept in
rows/, the summary is rewritten under a lock, so the last task to finish leaves the whole
summary).
"""
import fcntl
import json
import shlex
import sys
from pathlib import Path

from cli.batch import prepare_batch, run_job, write_summary
from common.files import record, write_text

SCRIPT = "batch.sbatch"
ROOT = Path(__file__).resolve().parents[1]


def write_script(jobs, cases, table, out):
    """out/batch.sbatch for these jobs (planned from `cases` and `table`); its path."""
    out = Path(out).resolve()
    prepare_batch(jobs, out)
    task = [sys.executable, "-m", "cli", "batch",
            *[str(Path(c).resolve()) for c in cases]]
    if table is not None:
        task += ["--table", str(Path(table).resolve())]
    task += ["--out", str(out), "--task"]
    names = ", ".join(f"{k}: {j.name}" for k, j in enumerate(jobs))
    ranks = max(_ranks(j) for j in jobs)      # a run on YADE's MPI: its ranks as tasks
    text = (f"#!/bin/bash\n"
            f"# {len(jobs)} runs of a batch, one per array task ({names})\n"
            f"#   sbatch {shlex.quote(str(out / SCRIPT))}\n"
            f"# (sbatch options given on its command line override the ones below)\n"
            f"#SBATCH --job-name={shlex.quote(out.name)}\n"
            f"#SBATCH --array=0-{len(jobs) - 1}\n"
            f"#SBATCH --ntasks={max(1, ranks)}\n"
            f"#SBATCH --cpus-per-task=1\n"
            f"#SBATCH --output={shlex.quote(str(out / 'logs' / 'slurm-%A_%a.out'))}\n"
            f"set -euo pipefail\n"
            f"cd {shlex.quote(str(ROOT))}\n"
            f"export OMP_NUM_THREADS=${{SLURM_CPUS_PER_TASK:-1}}\n"
            f"exec {shlex.join(task)} \"$SLURM_ARRAY_TASK_ID\"\n")
    path = out / SCRIPT
    write_text(path, text)
    path.chmod(0o755)
    return path


def _ranks(job):
    """The MPI ranks of a job's run (cli.mpi.case_ranks), 0 for one process or a case that
    does not load (its array task says why when it runs, as without MPI)."""
    from cases.kinds import load_case
    from cli.mpi import case_ranks
    try:
        return case_ranks(load_case(job.case, [f"{k}={v}" for k, v in job.overrides.items()]))
    except ValueError:
        return 0


def run_task(jobs, out, task):
    """Array task `task`: its run, its row, the summary of every row so far. Its row."""
    out = Path(out)
    if not (out / SCRIPT).is_file():
        raise ValueError(f"batch --task: {out} has no {SCRIPT}; write it with batch --slurm")
    if not 0 <= task < len(jobs):
        raise ValueError(f"batch --task {task}: the batch has {len(jobs)} runs, tasks 0 to "
                         f"{len(jobs) - 1}")
    row = run_job(jobs[task], out)
    rows = out / "rows"
    rows.mkdir(exist_ok=True)
    write_text(rows / f"{task:05d}.json", json.dumps(row))
    record(out / ".summary.lock")
    with open(out / ".summary.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        write_summary(out, [json.loads(p.read_text()) for p in sorted(rows.glob("*.json"))])
    return row
