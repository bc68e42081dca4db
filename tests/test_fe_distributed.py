"""The FE partner distributed under MPI, driven from rank 0, against the serial model."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).parent / "mpi" / "fe_against_serial.py"


def test_two_ranks_give_the_serial_model_to_round_off():
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMP_NUM_THREADS="1")
    proc = subprocess.run(["mpirun", "-n", "2", sys.executable, str(SCRIPT)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["ranks"] == 2
    assert r["fixed_mismatch"] == 0 and r["cells"][0] == r["cells"][1]
    # Set-up quantities are sums of the same element terms in another order: a few ulps.
    for key in ("nodes", "mass", "critical_dt", "critical_dt_bound", "k", "h", "von_mises_max"):
        assert r[key] < 1e-13, (key, r[key])
    # 300 explicit steps: PETSc's parallel mat-vec adds the on- and off-process parts of a row
    # separately, so each step differs from serial by a few ulps and the stable scheme
    # carries that forward additively: 300 steps x O(10 eps) stays below 1e-12.
    for key in ("u", "v", "kinetic_energy", "strain_energy"):
        assert r[key] < 1e-12, (key, r[key])


@pytest.mark.slow
def test_the_coupled_slab_runs_under_mpirun_as_in_serial(tmp_path):
    """`mpirun -n 2 ... slab --model coupled` (docs/mpi.md): the builder's check that every
    bridging sphere lies in an FE cell is collective, and the run gives the serial run's
    results to round-off (the FE sums rows in another order)."""
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMP_NUM_THREADS="1")
    slab = [sys.executable, "-m", "cli", "slab", "--model", "coupled", "--scale",
            "small", "--steps", "60", "--quiet", "--out"]
    root = Path(__file__).resolve().parents[1]
    for cmd in (["mpirun", "-n", "2"] + slab + [str(tmp_path / "mpi")],
                slab + [str(tmp_path / "serial")]):
        proc = subprocess.run(cmd, env=env, cwd=root, capture_output=True, text=True,
                              timeout=600)
        assert proc.returncode == 0, proc.stderr[-3000:]
    a, b = (json.loads((tmp_path / d / "summary.json").read_text()) for d in ("mpi", "serial"))
    for key in ("n_spheres", "n_fe_nodes", "n_bridging_spheres", "damage"):
        assert a[key] == b[key], key
    x, y = (np.loadtxt(tmp_path / d / "sensors.csv", delimiter=",", skiprows=1)
            for d in ("mpi", "serial"))
    peak = np.abs(y[:, 1:]).max()
    assert peak > 0 and np.abs(x - y).max() <= 1e-9 * peak
    assert a["fe_peak_stress"]["von_mises_Pa"] == pytest.approx(
        b["fe_peak_stress"]["von_mises_Pa"], rel=1e-9)
