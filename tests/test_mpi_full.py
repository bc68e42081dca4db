"""The full slab on YADE's own MPI (yade.mpy, `slab --model full --mpi N`) against the serial
run of the same seed (docs/mpi.md)."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from orchestrator.run.outputs import QUANTITIES, read_quantities
from yade_side.distributed import owners

STEPS = 150     # the impactor hits at step ~18: links across the slices load, crack, break


def _slab(out, *extra, env=None):
    cmd = [sys.executable, "-m", "cli", "slab", "--model", "full", "--scale", "small",
           "--steps", str(STEPS), "--quiet", "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, **(env or {})))


def test_owners_are_slices_along_x_of_equal_count():
    x = np.random.default_rng(1).uniform(0, 2.5, 1001)
    owner = owners(x, 3)
    assert set(owner) == {1, 2, 3}
    counts = np.bincount(owner)[1:]
    assert counts.max() - counts.min() <= 1
    for a, b in ((1, 2), (2, 3)):
        assert x[owner == a].max() < x[owner == b].min()


@pytest.mark.slow
def test_three_ranks_give_the_serial_run_to_round_off(tmp_path):
    """Rank 0 and two workers, the crack crossing the slices' boundary under the impactor.
    The workers sum a sphere's forces in another order than the serial loop (and the links
    across the boundary are computed on both ranks), so the runs differ by round-off that the
    explicit steps carry forward: measured 1e-15 m after 100 steps, 1.2e-10 m after 600.
    A link lost or a mirror sphere left stale shows at once (3 mm after 100 steps when the
    impactor's mirrors were not refreshed), far above the bound of 1e-6 of the peak."""
    serial, mpi = tmp_path / "serial", tmp_path / "mpi"
    for out, extra in ((serial, ("--threads", "1")), (mpi, ("--mpi", "3"))):
        proc = _slab(out, *extra)
        assert proc.returncode == 0, proc.stderr[-3000:]
    a, b = (np.loadtxt(f / "sensors.csv", delimiter=",", skiprows=1) for f in (serial, mpi))
    assert a.shape == b.shape
    assert np.abs(a - b).max() <= 1e-6 * np.abs(a[:, 1:]).max()
    # the quantities of interest too, each to 1e-6 of its peak (the forces: momentum
    # differences of the same round-off, over a sample interval)
    qa, qb = (read_quantities(f / QUANTITIES)[2] for f in (serial, mpi))
    assert qa.shape == qb.shape and np.array_equal(np.isnan(qa), np.isnan(qb))
    assert (np.nanmax(np.abs(qa - qb), axis=0) <= 1e-6 * np.nanmax(np.abs(qa), axis=0)).all()
    sa, sb = (json.loads((f / "summary.json").read_text()) for f in (serial, mpi))
    assert sb["spec"]["mpi"] == 3
    # the energy split reads one process's memory: the MPI run records none and says so
    assert sa["quantities"]["energy_split"] is not None
    assert sb["quantities"].get("energy_split") is None
    assert ("note: no energy split is recorded: its YADE scene is split over MPI ranks"
            in (mpi / "run.log").read_text())
    assert sa["n_spheres"] == sb["n_spheres"]
    assert sa["damage"]["initial_links"] == sb["damage"]["initial_links"]
    assert sa["damage"]["broken_links"] == sb["damage"]["broken_links"] > 0
    # each link's damage is the same to round-off: one at the threshold could flip (never
    # seen), else the maps are equal
    da, db = (np.load(f / "damage.npz") for f in (serial, mpi))
    assert np.abs(da["damage"] - db["damage"]).max() <= 1e-12
    # the two workers' slices meet under the impactor (x = 1.25 m): links across it broke
    x, radius = da["positions"][:, 0], da["radius"]
    boundary = np.abs(x - np.median(x)) < 2 * radius
    assert da["damage"][-1][boundary].max() > 0
    # the links' energy: each link across the boundary counted once (by its id1's owner)
    ea, eb = (np.array(s["energy"]) for s in (sa, sb))
    assert np.abs(ea - eb).max() <= 1e-9 * ea[:, 1].max()


@pytest.mark.parametrize("extra, message", [
    (("--mpi", "1"), "mpi must be 0 (one process) or >= 2"),
    (("--mpi", "3", "--dt-safety", "auto"), "not with dt_safety 'auto'"),
])
def test_bad_ranks_are_one_line(tmp_path, extra, message):
    proc = _slab(tmp_path / "x", *extra)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert message in proc.stderr


def test_mpi_with_the_coupled_model_is_one_line(tmp_path):
    cmd = [sys.executable, "-m", "cli", "slab", "--model", "coupled", "--mpi", "3", "--out",
           str(tmp_path / "x")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("error: slab: mpi = 3 runs the full model on YADE's MPI, "
                                   "not the coupled one (its FE runs under mpirun: "
                                   "docs/mpi.md)")


def test_mpi_without_mpiexec_is_one_line(tmp_path):
    proc = _slab(tmp_path / "x", "--mpi", "3", env={"PATH": str(tmp_path)})
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error: --mpi 3: no mpiexec on PATH")
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_slurm_array_of_mpi_runs_asks_for_their_ranks(tmp_path):
    from cli.main import main
    case = tmp_path / "full.toml"
    case.write_text('[case]\nname = "full"\nkind = "slab"\n[slab]\nmodel = "full"\nmpi = 3\n')
    assert main(["batch", str(case), "--slurm", "--out", str(tmp_path / "b")]) == 0
    assert "#SBATCH --ntasks=3\n" in (tmp_path / "b" / "batch.sbatch").read_text()


@pytest.mark.slow
def test_an_ensemble_runs_each_member_on_its_own_ranks(tmp_path):
    """Each member starts its own mpiexec, from an ensemble process that started MPI itself
    and (as under pytest-xdist) inherited the MPI state of a parent that had: neither may reach
    the members' mpiexec, which would fail."""
    from mpi4py import MPI       # this process's MPI state, inherited by the one below
    assert MPI.COMM_WORLD.size == 1
    cmd = [sys.executable, "-m", "cli", "slab", "--model", "full", "--scale", "small",
           "--steps", "20", "--mpi", "2", "--seeds", "1,2", "--quiet", "--out",
           str(tmp_path / "e")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for seed in (1, 2):
        s = json.loads((tmp_path / "e" / f"seed-{seed}" / "summary.json").read_text())
        assert s["spec"]["mpi"] == 2 and s["spec"]["seed"] == seed and s["steps"] == 20


@pytest.mark.slow
def test_a_stopped_mpi_run_says_so_in_one_line(tmp_path):
    """SIGTERM to the command reaches rank 0 (the workers ignore it), which ends its step and
    says why there is nothing to resume; exit code 143 as for a one-process run."""
    import signal
    import time
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "cli", "slab", "--model", "full", "--scale", "small",
           "--steps", "5000", "--check-every", "10", "--mpi", "2", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not ((out / "run.log").is_file() and "step 20," in (out / "run.log").read_text()):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 143
    assert err.strip().splitlines()[-1].startswith("stopped: stopped at step ")
    assert err.strip().endswith("no checkpoint (the YADE scene is split over MPI ranks)")


def _started(out, extra=()):
    """A 2-rank full run in a session of its own (as a terminal's foreground job), once its
    step 20 is logged."""
    import time
    cmd = [sys.executable, "-m", "cli", "slab", "--model", "full", "--scale", "small",
           "--steps", "5000", "--check-every", "10", "--mpi", "2", "--quiet", "--out", str(out),
           *extra]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 300
    while not ((out / "run.log").is_file() and "step 20," in (out / "run.log").read_text()):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    return proc


def _left(out):
    """The processes still running with `out` on their command line (mpiexec, its ranks)."""
    found = subprocess.run(["pgrep", "-f", "--", f"--out {out}"], capture_output=True, text=True)
    assert found.returncode in (0, 1), found.stderr        # 0: found, 1: none
    return found.stdout.split()


@pytest.mark.slow
def test_ctrl_c_stops_an_mpi_run_with_the_one_process_line(tmp_path):
    """Ctrl-C reaches the terminal's whole foreground group: the command, not mpiexec (in a
    session of its own), which it tells to stop; rank 0 ends its step and says why; 130."""
    import signal
    out = tmp_path / "run"
    proc = _started(out)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    assert "Broken pipe" not in err and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("stopped: stopped at step ")
    assert _left(out) == []


@pytest.mark.slow
def test_mpiexec_and_its_ranks_end_with_the_command_however_it_ends(tmp_path):
    """The command killed outright (SIGKILL, as `timeout -s KILL` would): mpiexec is told
    (PR_SET_PDEATHSIG) and ends its ranks."""
    import signal
    import time
    out = tmp_path / "run"
    proc = _started(out)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    deadline = time.monotonic() + 60
    while _left(out) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert _left(out) == []


@pytest.mark.parametrize("extra, message", [
    (("--mpi", "999"), "--mpi 999: 998 workers (every rank but rank 0, which drives) on"),
    (("--mpi", "2", "--checkpoint-every", "100"), "--checkpoint-every acts only on a run in one "
                                                  "process (an MPI run keeps no checkpoint"),
    (("--mpi", "2", "--seeds", "1,2,3", "--jobs", "3"), "3 runs × --mpi 2: 3 workers"),
])
def test_more_ranks_than_the_machine_holds_are_refused_before_mpiexec(tmp_path, extra,
                                                                      message, monkeypatch):
    """Bounded by this process's cores (here made 2): nothing is started, no folder made."""
    from cli.main import main
    monkeypatch.setattr(os, "sched_getaffinity", lambda _pid: {0, 1})
    assert main(["slab", "--model", "full", *extra, "--out", str(tmp_path / "x")]) == 2
    assert not (tmp_path / "x").exists() and _left(tmp_path / "x") == []


def test_a_model_built_for_more_ranks_than_the_process_has_is_refused():
    from cases.slab import SlabModel, SlabSpec
    with pytest.raises(ValueError, match=r"mpi = 3 runs on that many MPI ranks, this process "
                                         r"has 1"):
        SlabModel(SlabSpec(mpi=3, steps=10), "full")
