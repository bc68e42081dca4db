"""YADE's threads: every core by default for one run; one thread per member for ensembles and
side-by-side batch runs, which keeps each bit-identical to the same run made alone on one
thread (yade_side.import_yade)."""
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cli.main import build_parser

ROOT = Path(__file__).resolve().parents[1]


def test_a_run_takes_every_core_unless_told():
    script = ("from yade_side import cores, import_yade, yade_threads\n"
              "import_yade(); print(yade_threads(), cores())")
    env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.split()[-2:]
    assert out[0] == out[1] == str(len(os.sched_getaffinity(0)))
    out = subprocess.run([sys.executable, "-c", script], env=dict(env, OMP_NUM_THREADS="3"),
                         cwd=ROOT, check=True, capture_output=True, text=True).stdout.split()
    assert out[-2] == "3"


@pytest.mark.parametrize("options", [
    [],
    ["--scale", "medium", "--relaxation", "35", "--no-rotations", "--impactor-speed", "20.5",
     "--layers", "2", "--elastic-outside"],
    ["--zone", "auto", "--trip-omega", "0.2", "--dt-safety", "0.3", "--weighting", "nodal"],
])
def test_an_ensemble_member_is_the_same_seed_run_alone(options):
    from cases.slab import SlabSpec
    from cli.commands._options import spec_from_args
    from cli.commands.slab import _spec_argv
    parser = build_parser()
    ensemble = parser.parse_args(["slab", "--model", "full", *options, "--seeds", "4,7",
                                  "--out", "x"])
    spec = spec_from_args(SlabSpec, ensemble)
    for seed in (4, 7):
        alone = parser.parse_args(["slab", "--model", "full", *_spec_argv(ensemble, seed),
                                   "--out", "y"])
        assert spec_from_args(SlabSpec, alone) == replace(spec, seed=seed)


def test_side_by_side_batch_runs_take_one_thread_each(tmp_path, monkeypatch):
    from cli import batch
    seen = []
    monkeypatch.setattr(batch, "run_job", lambda job, out, env: seen.append(job.threads) or {
        "name": job.name, "case": str(job.case), "status": "ok", "error": "", "batch_wall_s": 0})
    jobs = [batch.Job("a", Path("a.toml")), batch.Job("b", Path("b.toml"), threads=2)]
    batch.run_batch(jobs, tmp_path, parallel=2)
    assert seen == [1, 2]
    seen.clear()
    batch.run_batch(jobs, tmp_path, parallel=1)
    assert seen == [None, 2]          # alone, a run takes the default: every core


@pytest.mark.slow
def test_ensemble_members_are_bit_identical_to_single_runs(tmp_path):
    env = dict(os.environ, DEM_FEM_CACHE=str(tmp_path / "cache"))
    common = ["slab", "--model", "coupled", "--zone", "box", "--steps", "40", "--output-every",
              "40", "--quiet"]
    run = lambda *a: subprocess.run([sys.executable, "-m", "cli", *common, *a],
                                    env=env, cwd=ROOT, check=True, capture_output=True)
    run("--seeds", "1,2", "--out", str(tmp_path / "ens"))
    run("--seed", "2", "--threads", "1", "--out", str(tmp_path / "alone"))
    a, b = tmp_path / "ens" / "seed-2", tmp_path / "alone"
    assert (a / "sensors.csv").read_bytes() == (b / "sensors.csv").read_bytes()
    with np.load(a / "damage.npz") as x, np.load(b / "damage.npz") as y:
        assert np.array_equal(x["positions"], y["positions"])
