"""ParaView's own readers on a short coupled run's outputs, and the `render` command
(pictures through pvpython); the bad inputs of `render` fail in one line."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

from cli.main import main
from cli.render import cut_point, pvpython_command
from yade_side.output import read_series

ROOT = Path(__file__).resolve().parents[1]
needs_paraview = pytest.mark.skipif(
    shutil.which("pvpython") is None or shutil.which("xvfb-run") is None,
    reason="ParaView not installed (make setup-paraview)")


@pytest.fixture(scope="module")
def coupled_run(tmp_path_factory):
    """block_impact over 86 steps, a frame every 17 and the last: 1,717 spheres and 1,248 FE
    nodes, the FE reached by the impact's wave in the last frames."""
    out = tmp_path_factory.mktemp("pv") / "run"
    subprocess.run([sys.executable, "-m", "cli", "run", "cases/block_impact.toml",
                    "--set", "time.duration=2e-4", "--set", "output.every=17", "--out",
                    str(out), "--quiet"], cwd=ROOT, check=True, capture_output=True,
                   env={**os.environ, "OMP_NUM_THREADS": "1"})
    return out


@pytest.mark.slow
@needs_paraview
def test_paraview_readers_see_every_frame_node_and_field(coupled_run):
    proc = subprocess.run(pvpython_command() + [str(ROOT / "tests" / "paraview_probe.py"),
                                                 str(coupled_run)],
                          capture_output=True, text=True, check=True)
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    summary = json.loads((coupled_run / "summary.json").read_text())
    spheres = read_series(coupled_run / "spheres.pvd")
    with meshio.xdmf.TimeSeriesReader(coupled_run / "fe.xdmf") as reader:
        nodes, cells = reader.read_points_cells()
        fe = [reader.read_data(k) for k in range(reader.num_steps)]
    assert len(spheres) == len(fe) == 7             # t = 0, every 17th of 86 steps, the last

    pvd = seen["PVDReader"]
    assert pvd["times"] == [t for t, _ in spheres]
    assert pvd["points"] == pvd["cells"] == summary["n_spheres"]
    assert pvd["point_arrays"] == {"damage": 1, "displacement": 3, "radius": 1,
                                   "rotation_speed": 3, "velocity": 3}
    last = np.linalg.norm(spheres[-1][1].point_data["displacement"], axis=1)
    assert pvd["displacement_magnitude"] == pytest.approx([last.min(), last.max()], rel=1e-12)
    assert last.max() > 0

    u = np.linalg.norm(fe[-1][1]["displacement"], axis=1)
    # every reader, the version-2 one included, sees one grid of the model's nodes, not
    # a second copy of the mesh
    for name in ("Xdmf3ReaderS", "Xdmf3ReaderT", "XDMFReader"):
        xdmf = seen[name]
        assert xdmf["type"] == "vtkUnstructuredGrid", name
        assert xdmf["times"] == [t for t, _, _ in fe], name
        assert xdmf["points"] == len(nodes) == summary["n_fe_nodes"], name
        assert xdmf["cells"] == sum(len(c.data) for c in cells), name
        assert xdmf["point_arrays"] == {"displacement": 3, "velocity": 3}, name
        assert xdmf["cell_arrays"] == {"max_principal": 1, "stress": 9, "von_mises": 1}, name
        assert xdmf["displacement_magnitude"] == pytest.approx([u.min(), u.max()], rel=1e-12)
    assert u.max() > 0


@pytest.mark.slow
@needs_paraview
def test_render_draws_the_chosen_frames_and_a_film(coupled_run, tmp_path, capsys):
    out = tmp_path / "pictures"
    assert main(["render", str(coupled_run), "--times", "0", "3e-5", "--animate",
                 "--out", str(out)]) == 0
    frames = [t for t, _ in read_series(coupled_run / "spheres.pvd")]
    printed = capsys.readouterr().out.splitlines()
    # 3e-5 s lies between the frames at 0 and 4.0e-5: the nearest one is drawn
    nearest = min(frames, key=lambda t: abs(t - 3e-5))
    pngs = sorted(out.glob("t_*.png"))
    assert [p.name for p in pngs] == sorted([f"t_{0.0:.4e}s.png", f"t_{nearest:.4e}s.png"])
    for png in pngs:
        data = png.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
        assert (width, height) == (1600, 900)
    movie = (out / "animation.avi").read_bytes()
    assert movie[:4] == b"RIFF" and movie[8:12] == b"AVI "
    assert printed[-1].startswith(f"{len(frames)} frames:")
    assert oct((out / "animation.avi").stat().st_mode & 0o777) == oct(0o644)


def test_render_of_a_folder_that_is_not_a_run_is_refused_in_one_line(tmp_path, capsys):
    (tmp_path / "summary.json").write_text("{}")
    assert main(["render", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: render: {tmp_path} is not a run's folder (it needs summary.json "
                   f"and spheres.pvd or fe.xdmf)\n")


def test_render_without_pvpython_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    (tmp_path / "summary.json").write_text("{}")
    (tmp_path / "fe.xdmf").write_text("")
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    assert main(["render", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == ("error: render: pvpython not found; install ParaView with `make "
                   "setup-paraview` (Debian: apt-get install python3-paraview xvfb xauth)\n")


def test_the_cut_goes_through_the_impact_sensor_else_the_centre(tmp_path):
    (tmp_path / "spheres.pvd").write_text("")
    (tmp_path / "summary.json").write_text(json.dumps(
        {"sensors": {"under_impact": {"position": [0.6, 0.59, 0.02]}}}))
    assert cut_point(tmp_path) == [0.6, 0.59, 0.02]
    (tmp_path / "summary.json").write_text(json.dumps({"sensors": {}}))
    assert cut_point(tmp_path) is None


def test_make_run_ends_with_pictures_or_says_how_to_install_paraview(tmp_path):
    make = (ROOT / "Makefile").read_text()
    run = make[make.index("\nrun: "):make.index("\n\n", make.index("\nrun: "))]
    assert run.splitlines()[-1].strip() == "@$(MAKE) --no-print-directory render"
    proc = subprocess.run([shutil.which("make"), "-s", "render"], cwd=ROOT, text=True,
                          capture_output=True, env={"PATH": str(tmp_path)})
    assert proc.returncode == 0
    assert proc.stdout == ("ParaView renders not made (ParaView is not installed: make "
                           "setup-paraview); the pictures are in "
                           "results/slab-small/10ms/compare/report.html\n")
