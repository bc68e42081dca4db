"""Batch runs, like yade-batch: many case files, or one case file with a parameter table,
N runs at a time. Each run is a separate `python3 -m orchestrator run` process (YADE's scene
is a process-wide singleton), writing its own results folder; the batch writes
`batch_summary.csv` (status, error, key results of every run) and `failures.txt`.

A parameter table is a CSV file whose header names dotted case-file keys
(`coupling.relaxation`), plus an optional `name` column for the run folders; each row is one
run. Values are TOML literals (`35`, `"full"`, `true`); anything else is taken as a string.
"""
import csv
import io
import json
import os
import re
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from time import perf_counter

from common.files import read_text, write_text

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass
class Job:
    name: str
    case: Path
    overrides: dict = field(default_factory=dict)

    def command(self, out):
        cmd = [sys.executable, "-m", "orchestrator", "run", str(self.case), "--out",
               str(out / self.name), "--quiet"]
        for key, value in self.overrides.items():
            cmd += ["--set", f"{key}={value}"]
        return cmd


def toml_value(text):
    """The value of a TOML literal, else the text itself as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def read_table(path):
    """[(name, {dotted key: raw text})] of a parameter table; rows are named by their `name`
    column, else run-001, run-002, ..."""
    path = Path(path)
    rows = list(csv.DictReader(io.StringIO(read_text(path, "parameter table"), newline=""),
                               skipinitialspace=True))
    if not rows:
        raise ValueError(f"parameter table {path} has no rows")
    out = []
    for i, row in enumerate(rows, start=1):
        if None in row or None in row.values():
            raise ValueError(f"parameter table {path}, row {i}: the number of values does not "
                             f"match the header")
        name = (row.pop("name", "") or f"run-{i:03d}").strip()
        for key, value in row.items():
            if not re.fullmatch(r"[A-Za-z_][\w]*(\.[A-Za-z_][\w]*)*", key.strip()):
                raise ValueError(f"parameter table {path}: column {key!r} is not a dotted "
                                 f"case-file key")
            if value.strip() == "":
                raise ValueError(f"parameter table {path}, row {i}: no value for {key!r}")
        out.append((name, {k.strip(): v.strip() for k, v in row.items()}))
    return out


def plan(cases, table=None):
    """The jobs of a batch: every case file alone, or the one case file once per table row."""
    cases = [Path(c) for c in cases]
    for c in cases:
        if not c.is_file():
            raise FileNotFoundError(f"case file {c} not found")
    if table is None:
        jobs = [Job(c.stem, c) for c in cases]
    else:
        if len(cases) != 1:
            raise ValueError(f"a parameter table goes with exactly one case file, got {len(cases)}")
        jobs = [Job(name, cases[0], overrides) for name, overrides in read_table(table)]
    names = [j.name for j in jobs]
    for name in names:
        if not _NAME.match(name):
            raise ValueError(f"run name {name!r} is not a valid folder name")
        if names.count(name) > 1:
            raise ValueError(f"two runs are named {name!r}: run names must be unique")
    return jobs


def run_batch(jobs, out, parallel=1, env=None):
    """Run the jobs `parallel` at a time into folder `out` (prepared by the caller); return
    the summary rows, in job order."""
    if int(parallel) != parallel or parallel < 1:
        raise ValueError(f"runs at a time must be an integer >= 1, got {parallel!r}")
    out = Path(out)
    (out / "logs").mkdir(exist_ok=True)
    env = dict(os.environ if env is None else env)
    env.setdefault("OMP_NUM_THREADS", "1")

    def one(job):
        t0 = perf_counter()
        with open(out / "logs" / f"{job.name}.log", "w") as log:
            proc = subprocess.run(job.command(out), stdout=log, stderr=subprocess.PIPE,
                                  text=True, env=env)
            log.write(proc.stderr)
        row = {"name": job.name, "case": str(job.case), "status": "ok", "error": "",
               "batch_wall_s": round(perf_counter() - t0, 3)}
        row.update({f"set.{k}": v for k, v in job.overrides.items()})
        if proc.returncode != 0:
            row["status"] = "failed"
            row["error"] = error_message(proc.stderr) or f"exit code {proc.returncode}"
        else:
            summary = out / job.name / "summary.json"
            if summary.is_file():     # its own `case` (the name) leaves the file's path
                row.update({k: v for k, v in key_results(json.loads(summary.read_text())).items()
                            if k not in row})
        return row

    with ThreadPoolExecutor(max_workers=int(parallel)) as pool:
        rows = list(pool.map(one, jobs))
    write_summary(out, rows)
    return rows


def error_message(stderr):
    """The run's error on one line: from its last `error:` line on (a case file's problems
    follow it, one per line), else its last line."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    starts = [i for i, line in enumerate(lines) if line.startswith(("error:", "stopped:"))]
    return " ".join(lines[starts[-1]:] if starts else lines[-1:])


def key_results(summary, prefix=""):
    """The scalar entries of a summary.json, nested dicts flattened to dotted keys (lists,
    such as energy histories, are left out)."""
    flat = {}
    for key, value in summary.items():
        if isinstance(value, dict):
            flat.update(key_results(value, f"{prefix}{key}."))
        elif isinstance(value, (int, float, str, bool)) or value is None:
            flat[f"{prefix}{key}"] = value
    return flat


def write_summary(out, rows):
    first = ["name", "case", "status", "error", "batch_wall_s"]
    columns = first + sorted({k for r in rows for k in r} - set(first))
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_text(Path(out) / "batch_summary.csv", text.getvalue())
    failed = [f"{r['name']}: {r['error']}" for r in rows if r["status"] != "ok"]
    write_text(Path(out) / "failures.txt", "".join(f"{line}\n" for line in failed))
