"""The same command gives the same results whatever ran before it: the slab run twice in fresh
packing caches, and once in a cache that already holds packings of other radii and seeds, gives
identical sphere sets and sensor histories, bit for bit (one OpenMP thread)."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
COMMAND = ["slab", "--model", "coupled", "--zone", "box", "--scale", "small", "--steps", "60",
           "--output-every", "60", "--quiet"]


def run(cache, out, before=None):
    env = dict(os.environ, DEM_FEM_CACHE=str(cache), OMP_NUM_THREADS="1")
    if before:
        subprocess.run([sys.executable, "-c", before], env=env, cwd=ROOT, check=True)
    subprocess.run([sys.executable, "-m", "cli", *COMMAND, "--out", str(out)],
                   env=env, cwd=ROOT, check=True, capture_output=True)
    with np.load(out / "damage.npz") as d:
        positions = d["positions"].copy()
    return positions, (out / "sensors.csv").read_bytes()


@pytest.mark.slow
def test_a_slab_run_does_not_depend_on_what_the_cache_holds(tmp_path):
    other = ("from yade_side.packing import dense_box_packing\n"
             "for r, s in ((0.02, 1), (0.03, 2), (0.025, 7)):\n"
             "    dense_box_packing((0, 0, 0), (0.5, 0.4, 0.3), r, seed=s)\n")
    a = run(tmp_path / "cache-a", tmp_path / "a")
    b = run(tmp_path / "cache-b", tmp_path / "b")
    c = run(tmp_path / "cache-c", tmp_path / "c", before=other)
    for x in (b, c):
        assert np.array_equal(a[0].view(np.int64), x[0].view(np.int64))
        assert a[1] == x[1]
    d = run(tmp_path / "cache-a", tmp_path / "d")      # the cache it made itself: the same
    assert a[1] == d[1]
