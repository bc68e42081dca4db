"""Batch runs, like yade-batch: many case files, or one case file with a parameter table,
N runs at a time. Each run is a separate `python3 -m cli run` process (YADE's scene
is a process-wide singleton), writing its own results folder; the batch writes
`batch_summary.csv` (status, error, key results of every run) and `failures.txt`.

A parameter table is either
- CSV: a header of dotted case-file keys (`coupling.relaxation`), plus an optional `name`
  column for the run folders; each row is one run. Values are TOML literals (`35`, `"full"`,
  `true`); anything else is taken as a string. Told apart by a comma in its header line.
- yade-batch's format (yade.utils.TableParamReader, whose rules are followed): whitespace
  columns, `#` comments, blank lines skipped but counted; the first line is the header; `=`
  repeats the value of the line above; a `description` column names the runs, else the
  description is built from the `!`-suffixed columns (from all columns if none is),
  `name=value` joined by commas, quotes removed, `__line=N__` appended to a repeated one.
  Values are Python literals, as yade-batch evaluates them. A dotted column is a case-file
  key; a plain one is a parameter of the case's YADE script, which reads its row with
  `yade.utils.readParamsFromTable()` as under yade-batch: each run gets YADE_BATCH=TABLE:LINE,
  TABLE being a copy of the table with the script's columns only (`script_params.table` in the
  batch folder, same line numbers), since readParamsFromTable refuses columns the script
  gives no default. `!THREADS` / `!OMP_NUM_THREADS` set the run's threads. (yade-batch keeps
  the `!` of column names when a description column is given; here it is always removed.)
"""
import ast
import csv
import io
import json
import os
import re
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from time import perf_counter

from common.files import read_text, record, write_text

# run folders; also yade-batch's built descriptions (`a=1,!OMP_NUM_THREADS=2`)
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._=,+!-]*$")
_KEY = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")
_THREADS = ("!THREADS", "!OMP_NUM_THREADS")
SCRIPT_TABLE = "script_params.table"


@dataclass
class Row:
    """One run of a parameter table: case-file overrides (TOML text), the YADE script's own
    parameters (yade-batch tables), the table's line number, the threads asked for."""
    name: str
    overrides: dict
    params: dict = field(default_factory=dict)
    line: int = None
    threads: int = None


@dataclass
class Job:
    name: str
    case: Path
    overrides: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    line: int = None             # of the table, for the script's readParamsFromTable
    threads: int = None
    script_table: str = None     # the text of SCRIPT_TABLE, when the script has columns

    def command(self, out):
        cmd = [sys.executable, "-m", "cli", "run", str(self.case), "--out",
               str(out / self.name), "--quiet"]
        for key, value in self.overrides.items():
            cmd += ["--set", f"{key}={value}"]
        if self.threads:
            cmd += ["--threads", str(self.threads)]
        return cmd

    def environment(self, out):
        """Variables this run adds to the batch's environment."""
        if self.script_table is None:
            return {}
        return {"YADE_BATCH": f"{Path(out).resolve() / SCRIPT_TABLE}:{self.line}"}


def toml_value(text):
    """The value of a TOML literal, else the text itself as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def read_table(path):
    """(rows, script_table) of a parameter table, CSV or yade-batch's format: [Row], and for
    a yade-batch table with script columns the text of its copy for readParamsFromTable
    (else None). CSV rows are named by their `name` column, else run-001, run-002, ..."""
    path = Path(path)
    text = read_text(path, "parameter table")
    # the header: the first line with more than a `#` comment (yade-batch's comments)
    header = next((line for line in text.splitlines() if re.sub(r"#.*", "", line).strip()), "")
    if "," in re.sub(r"#.*", "", header):
        return _read_csv(path, text), None
    return _read_yade_table(path, text)


def _read_csv(path, text):
    rows = list(csv.DictReader(io.StringIO(text), skipinitialspace=True))
    if not rows:
        raise ValueError(f"parameter table {path} has no rows")
    out = []
    for i, row in enumerate(rows, start=1):
        if None in row or None in row.values():
            raise ValueError(f"parameter table {path}, row {i}: the number of values does not "
                             f"match the header")
        name = (row.pop("name", "") or f"run-{i:03d}").strip()
        for key, value in row.items():
            if not _KEY.fullmatch(key.strip()):
                raise ValueError(f"parameter table {path}: column {key!r} is not a dotted "
                                 f"case-file key")
            if value.strip() == "":
                raise ValueError(f"parameter table {path}, row {i}: no value for {key!r}")
        out.append(Row(name, {k.strip(): v.strip() for k, v in row.items()}))
    return out


def _read_yade_table(path, text):
    """yade.utils.TableParamReader's rules (see the module's docstring)."""
    # 1-based line numbers, as readParamsFromTable and a text editor count them
    lines = {n: re.sub(r"\s*#.*", "", line).split()
             for n, line in enumerate(text.splitlines(), start=1)}
    used = [n for n, words in lines.items() if words]
    if len(used) < 2:
        raise ValueError(f"parameter table {path} has no rows")
    header_line, *data = used
    header = lines[header_line]
    for n in data:
        if len(lines[n]) != len(header):
            raise ValueError(
                f"parameter table {path} is neither CSV (a comma-separated header) nor a "
                f"yade-batch table (whitespace columns): line {n} has {len(lines[n])} values "
                f"for the {len(header)} columns of line {header_line}")
    bangs = [h[:-1] for h in header if h.endswith("!") and len(h) > 1]
    columns = [h[:-1] if h.endswith("!") and len(h) > 1 else h for h in header]
    if len(set(columns)) != len(columns):
        raise ValueError(f"parameter table {path}: a column is named twice in {header}")
    values = _repeat_above(path, columns, {n: lines[n] for n in data})
    script_cols = [c for c in columns if c != "description" and not c.startswith("!")
                   and "." not in c]
    rows = _yade_rows(path, values, bangs or columns, script_cols)
    if not script_cols:
        return rows, None
    # the script's columns only, on the original line numbers
    copy = [""] * max(used)
    copy[header_line - 1] = " ".join(script_cols + ["description"])
    for row, n in zip(rows, data):
        copy[n - 1] = " ".join([values[n][c] for c in script_cols] + [row.name])
    return rows, "\n".join(copy) + "\n"


def _repeat_above(path, columns, lines):
    """{line: {column: value}}, '=' taking the value of the line above."""
    values, previous = {}, None
    for n, words in lines.items():
        row = dict(zip(columns, words))
        for col, value in row.items():
            if value == "=":
                if previous is None:
                    raise ValueError(f"parameter table {path}, line {n}: '=' in column {col!r} "
                                     f"repeats the line above, but there is none")
                row[col] = previous[col]
        values[n] = previous = row
    return values


def _yade_rows(path, values, naming, script_cols):
    """A Row per table line: its name (the description, else the `naming` columns), its
    case-file overrides, its script parameters, its threads."""
    rows, seen = [], set()
    for n, row in values.items():
        if "description" in row:
            name = row["description"]
        else:
            name = ",".join(f"{c}={row[c]}" for c in naming)
            name = name.replace("'", "").replace('"', "")
            if name in seen:
                name += f"__line={n}__"
            seen.add(name)
        overrides, threads = {}, None
        for col, value in row.items():
            if col in _THREADS:
                threads = _threads(path, n, col, value)
            elif col.startswith("!"):
                raise ValueError(f"parameter table {path}: column {col!r} (a yade-batch job "
                                 f"setting) is not supported; {' and '.join(_THREADS)} are")
            elif "." in col:
                if not _KEY.fullmatch(col):
                    raise ValueError(f"parameter table {path}: column {col!r} is not a dotted "
                                     f"case-file key")
                overrides[col] = _python_to_toml(path, n, col, value)
        rows.append(Row(name, overrides, {c: row[c] for c in script_cols}, n, threads))
    return rows


def _threads(path, n, col, value):
    if not value.isdigit() or int(value) < 1:
        raise ValueError(f"parameter table {path}, line {n}: {col} must be an integer >= 1, "
                         f"got {value!r}")
    return int(value)


def _python_to_toml(path, n, col, value):
    """A yade-batch value (a Python literal) as TOML text for --set; any other text as it is
    (the case file's check then names it)."""
    import tomli_w
    try:
        v = ast.literal_eval(value)
        return tomli_w.dumps({"v": v}).strip()[len("v = "):]
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return value


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
        rows, script_table = read_table(table)
        jobs = [Job(r.name, cases[0], r.overrides, r.params, r.line, r.threads, script_table)
                for r in rows]
    names = [j.name for j in jobs]
    for name in names:
        if not _NAME.match(name):
            raise ValueError(f"run name {name!r} is not a valid folder name")
        if names.count(name) > 1:
            raise ValueError(f"two runs are named {name!r}: run names must be unique")
    return jobs


def prepare_batch(jobs, out):
    """What the runs need in the batch folder `out` before they start."""
    out = Path(out)
    (out / "logs").mkdir(exist_ok=True)
    tables = {j.script_table for j in jobs if j.script_table}
    if tables:
        write_text(out / SCRIPT_TABLE, tables.pop())


def run_job(job, out, env=None):
    """Run one job into out/<name>; its summary row."""
    out = Path(out)
    env = dict(os.environ if env is None else env)
    env.update(job.environment(out))
    t0 = perf_counter()
    record(out / "logs" / f"{job.name}.log")
    with open(out / "logs" / f"{job.name}.log", "w") as log:
        proc = subprocess.run(job.command(out), stdout=log, stderr=subprocess.PIPE,
                              text=True, env=env)
        log.write(proc.stderr)
    row = {"name": job.name, "case": str(job.case), "status": "ok", "error": "",
           "batch_wall_s": round(perf_counter() - t0, 3)}
    row.update({f"set.{k}": v for k, v in job.overrides.items()})
    row.update({f"param.{k}": v for k, v in job.params.items()})
    if proc.returncode != 0:
        row["status"] = "failed"
        row["error"] = error_message(proc.stderr) or f"exit code {proc.returncode}"
    else:
        summary = out / job.name / "summary.json"
        if summary.is_file():
            # its own `case` (the name) leaves the file's path in every row
            row.update({k: v for k, v in key_results(json.loads(summary.read_text())).items()
                        if k not in row})
    return row


def run_batch(jobs, out, parallel=1, env=None):
    """Run the jobs `parallel` at a time into folder `out` (prepared by the caller); return
    the summary rows, in job order. Runs side by side take one YADE thread each unless their
    row sets it (one run alone takes every core)."""
    if int(parallel) != parallel or parallel < 1:
        raise ValueError(f"runs at a time must be an integer >= 1, got {parallel!r}")
    if parallel > 1:
        jobs = [replace(job, threads=job.threads or 1) for job in jobs]
    prepare_batch(jobs, out)
    with ThreadPoolExecutor(max_workers=int(parallel)) as pool:
        rows = list(pool.map(lambda job: run_job(job, out, env), jobs))
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
