"""Batch runs (the Docker entrypoint) and the Docker image's install list."""
import csv
import re
from pathlib import Path

import pytest

from cli.batch import Job, key_results, plan, read_table, toml_value, write_summary

ROOT = Path(__file__).resolve().parents[1]


def test_dockerfile_installs_through_the_makefiles_setup_from_the_one_package_list():
    docker = (ROOT / "docker" / "Dockerfile").read_text()
    make = (ROOT / "Makefile").read_text()
    assert re.search(r"^FROM debian:bookworm$", docker, re.M)
    assert re.search(r"^RUN make setup\b", docker, re.M)
    assert "COPY . ." in docker
    # the Makefile's setup installs exactly the package list file, nothing else
    assert re.search(r"^PKGS\s*:=\s*\$\(shell grep -v '\^\\#' docker/packages\.txt\)$", make, re.M)
    assert re.search(r"apt-get install -y --no-install-recommends \$\(PKGS\)$", make, re.M)
    assert not re.search(r"apt-get install", docker.replace("install -y --no-install-recommends make", ""))


def test_parameter_table_rows_become_named_runs_with_toml_values(tmp_path):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "p.csv"
    table.write_text('name, coupling.relaxation, coupling.variant\nr10, 10, "full"\n, 3.5e1, diagonal\n')
    jobs = plan([case], table)
    assert [j.name for j in jobs] == ["r10", "run-002"]
    assert jobs[0].overrides == {"coupling.relaxation": "10", "coupling.variant": "full"}
    assert [toml_value(v) for v in jobs[1].overrides.values()] == [35.0, "diagonal"]
    assert toml_value("true") is True
    cmd = jobs[0].command(tmp_path / "out")
    assert cmd[-4:] == ["--set", "coupling.relaxation=10", "--set", "coupling.variant=full"]


@pytest.mark.parametrize("text, message", [
    ("name,a\nx,1,2\n", "does not match the header"),
    ("name,a b\nx,1\n", "not a dotted case-file key"),
    ("name,a\nx,\n", "no value for 'a'"),
    ("name,a\n", "has no rows"),
    ("name,a\nx,1\nx,2\n", "two runs are named 'x'"),
    ("name,a\n../x,1\n", "not a valid folder name"),
])
def test_bad_tables_are_refused_naming_the_problem(tmp_path, text, message):
    case = tmp_path / "c.toml"
    case.write_text("")
    table = tmp_path / "p.csv"
    table.write_text(text)
    with pytest.raises(ValueError, match=re.escape(message)):
        plan([case], table)


def test_a_table_needs_exactly_one_case_and_cases_must_exist(tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text("")
    b.write_text("")
    with pytest.raises(ValueError, match="exactly one case file"):
        plan([a, b], tmp_path / "p.csv")
    with pytest.raises(FileNotFoundError, match="nope.toml"):
        plan([tmp_path / "nope.toml"])
    assert [j.name for j in plan([a, b])] == ["a", "b"]


def test_summary_flattens_scalars_and_lists_failures(tmp_path):
    flat = key_results({"n": 3, "time_split_s": {"yade": 1.5}, "energy": [[0, 1]], "w": None})
    assert flat == {"n": 3, "time_split_s.yade": 1.5, "w": None}
    rows = [{"name": "a", "case": "c", "status": "ok", "error": "", "batch_wall_s": 1, **flat},
            {"name": "b", "case": "c", "status": "failed", "error": "error: bad r",
             "batch_wall_s": 0.5}]
    write_summary(tmp_path, rows)
    with open(tmp_path / "batch_summary.csv") as f:
        read = list(csv.DictReader(f))
    assert [r["status"] for r in read] == ["ok", "failed"]
    assert read[0]["time_split_s.yade"] == "1.5" and read[1]["time_split_s.yade"] == ""
    assert (tmp_path / "failures.txt").read_text() == "b: error: bad r\n"


def test_a_batch_runs_a_parameter_table_and_lists_its_failure(tmp_path):
    """The entrypoint outside Docker: one case, a table of two good rows and a bad one, two
    runs at a time; each run's folder, the summary CSV with key results, the failure named."""
    from cli.main import main
    table = tmp_path / "params.csv"
    table.write_text("name,coupling.relaxation,time.duration\n"
                     "r5,5.0,2e-5\nr20,20.0,2e-5\nbad,-1.0,2e-5\n")
    out = tmp_path / "batch"
    code = main(["batch", str(ROOT / "cases" / "block_impact.toml"), "--table", str(table),
                 "-j", "2", "--out", str(out)])
    assert code == 1  # one run failed
    with open(out / "batch_summary.csv") as f:
        rows = {r["name"]: r for r in csv.DictReader(f)}
    assert [rows[n]["status"] for n in ("r5", "r20", "bad")] == ["ok", "ok", "failed"]
    # the case file, whether the run succeeded or not
    assert {r["case"] for r in rows.values()} == {str(ROOT / "cases" / "block_impact.toml")}
    for name in ("r5", "r20"):
        assert (out / name / "summary.json").is_file() and (out / name / "spheres.pvd").is_file()
        assert int(rows[name]["steps"]) >= 1 and float(rows[name]["relaxation"]) == float(
            rows[name]["set.coupling.relaxation"])
    assert "coupling.relaxation" in rows["bad"]["error"]
    assert (out / "failures.txt").read_text().startswith("bad: error: case file")
    assert (out / "logs" / "r5.log").is_file()
