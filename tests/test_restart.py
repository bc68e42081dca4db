"""Runs stopped by SIGTERM or killed by SIGKILL, then resumed, end exactly as an uninterrupted
run: a checkpoint holds the whole state (YADE scene with its CPM history, FE, coupling, run
loop), the model is rebuilt deterministically, and with one OpenMP thread every sum is done in
the same order (until a contact new since the checkpoint forms: YADE's collider places it
elsewhere after a load, docs/case-files.md; this case ends bit-identical). Bad checkpoints
are refused before anything is loaded."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
import pytest

from cli.main import STOPPED, main
from common.files import unrecorded
from orchestrator.run.outputs import read_sensors
from yade_side.output import read_series

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "block_impact.toml"
SETTINGS = ["--set", "time.duration=2.4e-4", "--set", "output.every=20",
            "--set", "output.checkpoint_every=100", "--quiet"]  # 341 steps, links break from ~260


def start(out):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, "-m", "cli", "run", str(CASE), "--out",
                             str(out), *SETTINGS], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def wait_for_checkpoint(out, step, proc):
    meta = out / "checkpoint" / "meta.json"
    while proc.poll() is None:
        if meta.is_file() and json.loads(meta.read_text())["step"] >= step:
            return
        time.sleep(0.05)
    pytest.fail(f"the run ended before its checkpoint of step {step}: {proc.stderr.read()}")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("restart") / "reference"
    assert main(["run", str(CASE), "--out", str(out), *SETTINGS]) == 0
    return out


def same_bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def assert_same_results(a, b):
    (ta, na, ha), (tb, nb, hb) = read_sensors(a / "sensors.csv"), read_sensors(b / "sensors.csv")
    assert na == nb and same_bits(ta, tb) and same_bits(ha, hb)
    assert np.abs(ha).max() > 1e-5  # the impact moved the sensors
    da, db = np.load(a / "damage.npz"), np.load(b / "damage.npz")
    assert same_bits(da["times"], db["times"]) and same_bits(da["damage"], db["damage"])
    assert da["damage"][-1].max() > 0  # links broke
    for (t1, m1), (t2, m2) in zip(read_series(a / "spheres.pvd"), read_series(b / "spheres.pvd"),
                                  strict=True):
        assert t1 == t2 and same_bits(m1.points, m2.points)
        assert same_bits(m1.point_data["damage"], m2.point_data["damage"])
    with meshio.xdmf.TimeSeriesReader(a / "fe.xdmf") as ra, \
            meshio.xdmf.TimeSeriesReader(b / "fe.xdmf") as rb:
        ra.read_points_cells(), rb.read_points_cells()
        assert ra.num_steps == rb.num_steps == len(da["times"])
        for k in range(ra.num_steps):
            (t1, p1, c1), (t2, p2, c2) = ra.read_data(k), rb.read_data(k)
            assert t1 == t2 and same_bits(p1["displacement"], p2["displacement"])
            assert same_bits(c1["stress"][0], c2["stress"][0])
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert sa["energy"] == sb["energy"] and sa["damage"] == sb["damage"]
    assert sa["constraint_gap"] == sb["constraint_gap"] and len(sa["constraint_gap"]) > 1
    assert sa["fe_peak_stress"] == sb["fe_peak_stress"]    # the checkpoint carries the peak
    assert sa["fe_peak_stress"]["von_mises_Pa"] > 0


@pytest.mark.parametrize("sig", [pytest.param(signal.SIGTERM, marks=pytest.mark.slow),
                                 signal.SIGKILL])
def test_a_stopped_run_resumes_to_the_uninterrupted_results(reference, tmp_path, sig):
    out = tmp_path / "run"
    proc = start(out)
    wait_for_checkpoint(out, 100, proc)
    proc.send_signal(sig)
    code = proc.wait(timeout=300)
    if sig == signal.SIGTERM:  # it finishes its step, writes a checkpoint and says so
        assert code == STOPPED, proc.stderr.read()
        assert "resume with --resume" in proc.stderr.read()
    else:
        assert code == -signal.SIGKILL
    assert not (out / "summary.json").exists()
    assert main(["run", "--resume", str(out), "--quiet"]) == 0
    assert_same_results(reference, out)
    assert unrecorded(out) == unrecorded(reference) == []   # --force may replace them whole


def test_a_mismatched_or_corrupt_checkpoint_is_refused(reference, tmp_path, capsys):
    out = tmp_path / "run"
    proc = start(out)
    wait_for_checkpoint(out, 100, proc)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=300) == STOPPED
    case = out / "case.toml"
    text = case.read_text()
    case.write_text(text.replace("layers = 2", "layers = 1"))
    assert main(["run", "--resume", str(out), "--quiet"]) == 2
    assert "coupling.layers: 2 at the checkpoint, 1 now" in capsys.readouterr().err
    case.write_text(text)
    state = out / "checkpoint" / "state.npz"
    state.write_bytes(state.read_bytes()[:1000])
    assert main(["run", "--resume", str(out), "--quiet"]) == 2
    assert "state.npz: unreadable checkpoint file" in capsys.readouterr().err
    assert not (out / "summary.json").exists()
    assert main(["run", "--resume", str(tmp_path / "nowhere"), "--quiet"]) == 2
    assert "no checkpoint to resume from" in capsys.readouterr().err
