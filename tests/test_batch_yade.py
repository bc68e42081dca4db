"""yade-batch's parameter tables in `batch` (read as YADE's own TableParamReader reads them),
a user script reading its row with readParamsFromTable, and Slurm job arrays."""
import csv
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from cli.batch import SCRIPT_TABLE, plan, read_table
from cli.main import main
from yade_side import import_yade
from yade_side.output import read_series

ROOT = Path(__file__).resolve().parents[1]

TABLES = {
    "bangs": """# a sweep, as a YADE user writes it
coupling.relaxation!   time.duration   speed!   coupling.variant
5                      4e-5            20       'full'

10                     =               =        =        # the line above's values
'a'                    1e-4            =        "diagonal"
""",
    "description": """speed   coupling.relaxation  description
1.5     5                    first
=       20                   second   # a comment
""",
    "no bangs, repeated descriptions": """coupling.variant   time.steps
diagonal           10
=                  =
full               10
""",
}


@pytest.mark.parametrize("text", TABLES.values(), ids=TABLES.keys())
def test_yade_batch_tables_are_read_as_yades_own_reader_reads_them(tmp_path, text):
    import_yade()
    from yade.utils import TableParamReader
    table = tmp_path / "params.table"
    table.write_text(text)
    theirs = TableParamReader(str(table)).paramDict()
    rows, _ = read_table(table)
    assert [r.name for r in rows] == [theirs[n]["description"] for n in sorted(theirs)]
    assert [r.line for r in rows] == sorted(theirs)
    for row in rows:
        line = theirs[row.line]
        values = {k.rstrip("!"): v for k, v in line.items() if k != "description"}
        assert row.params == {k: v for k, v in values.items() if "." not in k}
        assert set(row.overrides) == {k for k in values if "." in k}


def test_yade_values_become_toml_and_script_columns_a_copy_on_the_same_lines(tmp_path):
    table = tmp_path / "params.table"
    table.write_text(TABLES["bangs"])
    case = tmp_path / "c.toml"
    case.write_text("")
    jobs = plan([case], table)
    assert [j.name for j in jobs] == ["coupling.relaxation=5,speed=20",
                                      "coupling.relaxation=10,speed=20",
                                      "coupling.relaxation=a,speed=20"]
    assert jobs[1].overrides == {"coupling.relaxation": "10", "time.duration": "4e-05",
                                 "coupling.variant": '"full"'}
    assert jobs[2].overrides["coupling.relaxation"] == '"a"'
    assert [j.line for j in jobs] == [3, 5, 6]
    assert jobs[0].script_table.splitlines()[2:6] == [
        "20 coupling.relaxation=5,speed=20", "", "20 coupling.relaxation=10,speed=20",
        "20 coupling.relaxation=a,speed=20"]
    assert jobs[0].environment(tmp_path) == {"YADE_BATCH": f"{tmp_path / SCRIPT_TABLE}:3"}
    cmd = jobs[0].command(tmp_path)
    assert cmd[cmd.index("--set") + 1] == "coupling.relaxation=5"


def test_threads_column_and_unsupported_job_settings(tmp_path):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "t"
    table.write_text("coupling.relaxation !OMP_NUM_THREADS\n5 2\n")
    job, = plan([case], table)
    assert job.threads == 2 and job.command(tmp_path)[-2:] == ["--threads", "2"]
    assert job.script_table is None and job.environment(tmp_path) == {}  # no script columns
    table.write_text("coupling.relaxation !EXEC\n5 yade\n")
    with pytest.raises(ValueError, match=r"column '!EXEC' \(a yade-batch job setting\) is not "
                                         r"supported; !THREADS and !OMP_NUM_THREADS are"):
        plan([case], table)


@pytest.mark.parametrize("text, message", [
    ("a b\n1,2\n3 4\n", "is neither CSV (a comma-separated header) nor a yade-batch table "
                        "(whitespace columns): line 2 has 1 values for the 2 columns of line 1"),
    ("\n# only a header\nspeed\n", "has no rows"),
    ("speed\n=\n", "line 2: '=' in column 'speed' repeats the line above, but there is none"),
    ("a.b a.b\n1 2\n", "a column is named twice"),
    ("a..b\n1\n", "column 'a..b' is not a dotted case-file key"),
    ("!THREADS\n0\n", "line 2: !THREADS must be an integer >= 1, got '0'"),
    ("x description\n1 ../up\n", "run name '../up' is not a valid folder name"),
])
def test_bad_yade_tables_are_refused_in_one_line(tmp_path, capsys, text, message):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "p.table"
    table.write_text(text)
    assert main(["batch", str(case), "--table", str(table), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_a_binary_table_is_refused_in_one_line(tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "p.bin"
    table.write_bytes(b"\xff\xfe\x00\x01")
    assert main(["batch", str(case), "--table", str(table), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (f"error: parameter table {table} is not UTF-8 text: "
                                       f"byte 0xff at position 0 (line 1, column 1)\n")


# --- a YADE script reading its row --------------------------------------------------------

def speed_case(tmp_path):
    """block_impact whose script takes the impactor's speed from its table row
    (readParamsFromTable, default 30 m/s), over 2 steps."""
    script = (ROOT / "cases" / "scripts" / "block_impact.py").read_text()
    assert "state.vel = (0, 0, -30)" in script
    script = ("readParamsFromTable(speed=30.0)\nfrom yade.params.table import speed\n"
              + script.replace("state.vel = (0, 0, -30)", "state.vel = (0, 0, -speed)"))
    (tmp_path / "speed.py").write_text(script)
    case = (ROOT / "cases" / "block_impact.toml").read_text()
    case = case.replace('script = "scripts/block_impact.py"', 'script = "speed.py"')
    case = re.sub(r"duration = 4e-4", "duration = 4e-6", case)
    path = tmp_path / "speed.toml"
    path.write_text(case)
    return path


def impactor_speed(run):
    """The impactor's speed in the run's first frame (nothing has touched it yet)."""
    _, first = read_series(run / "spheres.pvd")[0]
    return -first.point_data["velocity"][:, 2].min()


def run_env():
    env = {k: v for k, v in os.environ.items() if k != "YADE_BATCH"}
    return {**env, "OMP_NUM_THREADS": "1"}


@pytest.mark.slow
def test_a_script_reads_its_row_under_run_and_batch(tmp_path):
    case = speed_case(tmp_path)
    table = tmp_path / "speeds.table"
    table.write_text("speed!  coupling.relaxation\n12.5    5\n25      =\n")
    # `run` alone: the script's defaults, or the row YADE_BATCH names, as under yade-batch
    # (a table of the script's own parameters: readParamsFromTable refuses any other column)
    own = tmp_path / "own.table"
    own.write_text("speed\n12.5\n25\n")
    for env, out, speed in ((run_env(), "alone", 30.0),
                            ({**run_env(), "YADE_BATCH": f"{own}:3"}, "row3", 25.0)):
        subprocess.run([sys.executable, "-m", "cli", "run", str(case), "--out",
                        str(tmp_path / out), "--quiet"], cwd=ROOT, env=env, check=True,
                       capture_output=True)
        assert impactor_speed(tmp_path / out) == speed
    subprocess.run([sys.executable, "-m", "cli", "batch", str(case), "--table",
                    str(table), "--out", str(tmp_path / "sweep")], cwd=ROOT, env=run_env(),
                   check=True, capture_output=True)
    with open(tmp_path / "sweep" / "batch_summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["name"], r["status"], r["param.speed"]) for r in rows] == [
        ("speed=12.5", "ok", "12.5"), ("speed=25", "ok", "25")]
    assert [float(r["relaxation"]) for r in rows] == [5.0, 5.0]
    assert [impactor_speed(tmp_path / "sweep" / r["name"]) for r in rows] == [12.5, 25.0]


# --- Slurm job arrays ----------------------------------------------------------------------

def test_slurm_with_j_is_refused_in_one_line(tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_text("")
    assert main(["batch", str(case), "--slurm", "-j", "2", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (
        "error: --slurm runs each run as its own array task: -j (runs at a time on this "
        "machine) does not apply; give one or the other\n")
    assert not (tmp_path / "o").exists()


def test_slurm_script_has_one_array_task_per_row(tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "p.csv"
    table.write_text("name,coupling.relaxation\na,5\nb,10\nc,20\n")
    out = tmp_path / "sweep"
    assert main(["batch", str(case), "--table", str(table), "--slurm", "--out", str(out)]) == 0
    script = (out / "batch.sbatch").read_text()
    assert "#SBATCH --array=0-2\n" in script
    assert script.splitlines()[-1] == (
        f"exec {sys.executable} -m cli batch {case} --table {table} --out {out} "
        f'--task "$SLURM_ARRAY_TASK_ID"')
    assert oct((out / "batch.sbatch").stat().st_mode & 0o777) == oct(0o755)
    assert capsys.readouterr().out.endswith(f"submit with: sbatch {out / 'batch.sbatch'}\n")
    assert main(["batch", str(case), "--table", str(table), "--out", str(out), "--task",
                 "3"]) == 2
    assert "batch --task 3: the batch has 3 runs, tasks 0 to 2" in capsys.readouterr().err


def slurm_batch(tmp_path):
    """`batch --slurm` of a 2-row yade-batch table of a short block_impact: its folder."""
    table = tmp_path / "p.table"
    table.write_text("coupling.relaxation time.duration description\n5 4e-6 r5\n20 = r20\n")
    out = tmp_path / "sweep"
    subprocess.run([sys.executable, "-m", "cli", "batch", "cases/block_impact.toml",
                    "--table", str(table), "--slurm", "--out", str(out)], cwd=ROOT,
                   check=True, capture_output=True)
    return out


@pytest.mark.slow
def test_each_array_task_runs_its_row_as_slurm_would(tmp_path):
    out = slurm_batch(tmp_path)
    for task in (1, 0):           # in any order, from any folder, as the array's tasks
        subprocess.run(["bash", str(out / "batch.sbatch")], cwd=tmp_path, check=True,
                       env={**run_env(), "SLURM_ARRAY_TASK_ID": str(task),
                            "SLURM_CPUS_PER_TASK": "1"}, capture_output=True)
    with open(out / "batch_summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["name"], r["status"], float(r["relaxation"])) for r in rows] == [
        ("r5", "ok", 5.0), ("r20", "ok", 20.0)]
    assert json.loads((out / "r20" / "summary.json").read_text())["relaxation"] == 20.0


def slurm_cluster_up():
    return shutil.which("sbatch") is not None and subprocess.run(
        ["sinfo", "-h", "-o", "%T"], capture_output=True, text=True).stdout.strip() == "idle"


@pytest.mark.slow
@pytest.mark.skipif(not slurm_cluster_up(), reason="no idle Slurm node (docker/slurm-node.sh)")
def test_a_job_array_on_a_single_node_slurm(tmp_path):
    out = slurm_batch(tmp_path)
    subprocess.run(["sbatch", "--wait", str(out / "batch.sbatch")], check=True,
                   capture_output=True, timeout=600)
    with open(out / "batch_summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert sorted((r["name"], r["status"]) for r in rows) == [("r20", "ok"), ("r5", "ok")]
