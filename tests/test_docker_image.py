"""The Docker image, built and run: `make docker-test` runs docker/test-image.sh (build from
docker/Dockerfile, the batch entrypoint on a 2-row table inside a container) and then these
checks of what the container wrote, on the host. Skipped unless DOCKER_TEST_OUT names the
script's output folder (the build takes several minutes)."""
import csv
import json
import os
import stat
import subprocess
from pathlib import Path

import meshio
import pytest

from yade_side.output import read_series

OUT = os.environ.get("DOCKER_TEST_OUT")
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not OUT, reason="run by `make docker-test` (builds the image)")]


@pytest.fixture(scope="module")
def out():
    return Path(OUT)


def test_the_image_was_built_and_measured(out):
    image = json.loads((out / "image.json").read_text())
    assert image["engine"] in ("docker", "podman") and image["base"] in ("registry", "mmdebstrap", "local")
    assert image["build_s"] > 0 and image["size_bytes"] > 1e9


def test_the_entrypoint_ran_both_rows_of_the_table(out):
    with open(out / "sweep" / "batch_summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["name"] for r in rows] == ["r5", "r20"]
    assert [r["status"] for r in rows] == ["ok", "ok"], [r["error"] for r in rows]
    assert (out / "sweep" / "failures.txt").read_text() == ""
    for row, r in zip(rows, (5.0, 20.0)):
        assert row["set.coupling.relaxation"] == str(int(r))
        assert float(row["relaxation"]) == r                  # the run used the row's value
        run = out / "sweep" / row["name"]
        summary = json.loads((run / "summary.json").read_text())
        assert summary["relaxation"] == r
        dt = summary["dt"]
        assert summary["steps"] == int(-(-4e-5 // dt))      # time.duration = 4e-5 s
        frames = read_series(run / "spheres.pvd")
        assert len(frames[-1][1].points) == summary["n_spheres"]
        with meshio.xdmf.TimeSeriesReader(run / "fe.xdmf") as reader:
            nodes, _ = reader.read_points_cells()
            assert len(nodes) == summary["n_fe_nodes"] and reader.num_steps == len(frames)


def test_every_output_is_readable_by_a_user_other_than_root(out):
    unreadable = [str(p.relative_to(out)) for p in (out / "sweep").rglob("*")
                  if not p.stat().st_mode & stat.S_IROTH
                  or (p.is_dir() and not p.stat().st_mode & stat.S_IXOTH)]
    assert unreadable == []
    # and really read as `nobody`, through the folders above
    subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "cat",
                    str(out / "sweep" / "batch_summary.csv")], check=True, capture_output=True)
