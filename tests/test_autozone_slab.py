"""The slab's auto zone end to end at small scale, kept cheap by few steps and low trip
levels: a start zone too small grows and ends clean, and its last attempt is the fixed-zone
run with the final zone, bit for bit; the limit path and the full-model fallback."""
import json
from dataclasses import replace

import numpy as np
import pytest

from cli.main import main

pytestmark = pytest.mark.slow
STEPS = 100   # contact at step ~33; σ1 passes 0.05 ft at step ~90 with a 0.3 m start zone
AUTO = ["slab", "--model", "coupled", "--scale", "small", "--zone", "auto", "--zone-start",
        "0.3", "--steps", str(STEPS), "--output-every", "50", "--quiet",
        "--zone-cost", "0"]   # no budget: the last option, so a test can set one


@pytest.fixture(scope="module")
def grown(tmp_path_factory):
    out = tmp_path_factory.mktemp("auto") / "grown"
    assert main(AUTO + ["--trip-stress", "0.05", "--out", str(out)]) == 0
    return out


def test_a_small_start_zone_grows_and_ends_clean(grown):
    s = json.loads((grown / "summary.json").read_text())
    attempts = s["zone_attempts"]
    assert s["zone_outcome"] == "clean" and len(attempts) >= 2
    assert all(a["tripped_step"] for a in attempts[:-1]) and attempts[-1]["tripped_step"] is None
    assert attempts[-1]["steps_run"] == STEPS
    cells = [a["cells"] for a in attempts]
    assert cells == sorted(cells) and cells[0] < cells[-1] == s["zone_final"]["n_cells"]
    assert s["zone_total_wall_s"] >= sum(a["wall_s"] for a in attempts) * 0.999
    assert s["full_model_projected"]["spheres"] > attempts[-1]["spheres"]
    assert (grown / "attempt-1" / "run.log").is_file() and not (grown / f"attempt-{len(attempts)}").exists()
    assert (grown / "zones.png").stat().st_size > 0 and (grown / "sensors.csv").is_file()


def test_auto_equals_the_fixed_run_with_its_final_zone(grown, tmp_path):
    from cases.slab import SlabModel, SlabSpec
    from cases.slab.model import run_built
    from cases.slab.zone import slab_grid, zone_grid
    s = json.loads((grown / "summary.json").read_text())
    spec = SlabSpec(**s["spec"])
    mask = np.zeros((15, 12), bool)
    mask[tuple(np.array(s["zone_final"]["cells"]).T)] = True
    fixed = run_built(SlabModel(replace(spec, zone="box"), "coupled",
                                zone_grid(slab_grid(spec), mask)), tmp_path, quiet=True)
    assert (tmp_path / "sensors.csv").read_bytes() == (grown / "sensors.csv").read_bytes()
    for key in ("sensors", "damage", "energy", "constraint_gap", "coupling_energy_J",
                "n_spheres", "n_fe_nodes", "n_bridging_spheres"):
        assert json.loads(json.dumps(fixed[key])) == s[key], key
    a, b = np.load(tmp_path / "damage.npz"), np.load(grown / "damage.npz")
    for key in ("damage", "positions"):
        assert np.array_equal(a[key], b[key])


def test_the_limit_ends_the_search_and_the_fallback_runs_the_full_model(tmp_path, capsys):
    """Checked once at step 100, FE cells beyond the limit (a strip of the start zone's 3
    columns) pass 0.001 ft: one line, exit code 1; with --fallback full the full model runs
    in the folder instead."""
    low = ["--trip-stress", "0.001", "--stress-every", "100", "--zone-limit", "0.5"]
    assert main(AUTO + low + ["--out", str(tmp_path / "limit")]) == 1
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("coupling cannot pay for this impact, because what the DE "
                           "zone must hold spreads too far: after 1 attempts, the last "
                           "tripped at step 100 by FE σ1")
    s = json.loads((tmp_path / "limit" / "summary.json").read_text())
    assert s["zone_outcome"] == "limit" and s["zone_message"] == line
    assert main(AUTO + low + ["--fallback", "full", "--out", str(tmp_path / "full")]) == 0
    s = json.loads((tmp_path / "full" / "summary.json").read_text())
    assert s["model"] == "full" and s["zone_fallback"] == "full" and s["zone_outcome"] == "limit"
    assert s["n_spheres"] == s["full_model_projected"]["spheres"]


def test_the_budget_ends_the_search_with_its_line(tmp_path, capsys):
    """The grown case's first attempt trips (σ1 ≥ 0.05 ft); a budget of 0.01 × the full
    model's sphere steps is spent by then: one line that names the budget, exit code 1."""
    args = AUTO[:-1] + ["0.01", "--trip-stress", "0.05", "--out", str(tmp_path)]
    assert main(args) == 1
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("coupling cannot pay for this impact, because what the DE "
                           "zone must hold spreads too far: after 1 attempts, the last "
                           "tripped at step ")
    assert " by FE σ1 " in line
    assert "would cost more than the full model (zone.cost) in another attempt" in line
    s = json.loads((tmp_path / "summary.json").read_text())
    assert (s["zone_outcome"], s["zone_limit_reached"]) == ("limit", "cost")
