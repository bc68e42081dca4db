"""`compare` of slab runs and ensembles, on synthetic results folders with known figures."""
import json

import numpy as np
import pytest

from common.files import save_npz, write_json
from cli.main import main
from cases.slab.quantities import NAMES as QOI, SENSE, Quantities, kind
from orchestrator.run.outputs import QUANTITIES, write_quantities, write_sensors

NAMES = ["under_impact", "de_zone", "bridging", "fe_node"]
T = np.linspace(0.0, 1e-3, 101)
SHAPE = np.sin(np.pi * T / T[-1])          # peak 1 at mid-window


def member(folder, model, seed, amplitude, scale="small", s_per_step=1.0, volume=1.0,
           end=T[-1]):
    """A results folder whose z histories are amplitude × SHAPE on every sensor until `end`;
    10 slab spheres (the coupled model keeps the first 6, 4 of them in its DE zone)."""
    folder.mkdir(parents=True)
    spec = {"scale": scale, "radius": 0.025, "impactor_speed": 40.0, "impactor_side": 0.3,
            "impactor_gap": 0.002, "steps": 100, "dt_safety": 0.15, "de_zone": 0.6,
            "full_width": True, "layers": 3, "seed": seed, "elastic_outside": False,
            "fe_ratio": 3.0}
    write_json(folder / "summary.json", {
        "model": model, "spec": spec, "s_per_step": s_per_step, "n_spheres": 10 if model ==
        "full" else 6, "damage": {"damaged_volume_m3": volume, "broken_links": 10 * volume},
        "quantities": {**Quantities.definitions(),
                       "cracking_energy": {"slab_J": 100.0 * amplitude}}})
    h = np.zeros((len(T), len(NAMES), 3))
    h[:, :, 2] = amplitude * SHAPE[:, None]
    write_sensors(folder / "sensors.csv", NAMES, T * end / T[-1], h)
    write_quantities(folder / QUANTITIES, QOI, T * end / T[-1], amplitude * qoi_shape())
    n = 10 if model == "full" else 6
    damage = np.linspace(0, 1, 10)[:n]
    save_npz(folder / "damage.npz", times=np.array([0.0, T[-1]]),
             damage=np.array([np.zeros(n), damage]), positions=np.random.default_rng(seed)
             .uniform((0, 0, 0), (2.5, 2.0, 0.28), (n, 3)), radius=np.full(n, 0.025),
             in_de_zone=np.arange(n) < 4, slab_index=np.arange(n),
             # the cracking energy: 100 × amplitude J, split over two plan cells
             crack_points=np.array([[1.2, 1.0, 0.1], [1.3, 1.0, 0.1]]),
             crack_energy=np.array([75.0, 25.0]) * amplitude, crack_fe=np.zeros(2, bool))
    return folder


def qoi_shape():
    """SHAPE in every QoI's sense (down for the displacements, up for the rest)."""
    return np.column_stack([(-1 if SENSE[kind(n)] < 0 else 1) * SHAPE for n in QOI])


def test_one_pair_keeps_its_figures_at_the_top(tmp_path):
    member(tmp_path / "f", "full", 1, 2.0, s_per_step=3.0)
    member(tmp_path / "c", "coupled", 1, 1.5, volume=0.5)
    assert main(["compare", str(tmp_path / "f"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "cmp")]) == 0
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    s = r["sensors"]["bridging"]
    assert s["peak_ratio"] == pytest.approx(0.75, rel=1e-12)
    # nRMS of 0.5 SHAPE against a peak of 2: 0.25 × rms(SHAPE)
    assert s["nrms"] == pytest.approx(0.25 * np.sqrt(np.mean(SHAPE**2)), rel=1e-9)
    assert r["speedup_per_step"] == 3.0 and r["damage"]["damaged_volume_ratio"] == 0.5
    assert r["damage"]["damage_map_correlation_de_zone"] == pytest.approx(1.0)
    assert "ensemble" not in r and r["goals"]["peaks_within_10_percent"] is False


def test_ensembles_are_judged_against_the_full_scatter(tmp_path):
    """Full members 0.9, 1.0, 1.1 × SHAPE: member i's leave-one-out deviation is |a_i − mean of
    the others| / mean of the others; coupled 1.02 lies inside, 1.5 outside."""
    for seed, a in zip((1, 2, 3), (0.9, 1.0, 1.1)):
        member(tmp_path / "full" / f"seed-{seed}", "full", seed, a)
    for seed, a in zip((1, 2), (1.02, 1.0)):
        member(tmp_path / "good" / f"seed-{seed}", "coupled", seed, a)
    member(tmp_path / "bad" / "seed-1", "coupled", 1, 1.5)
    for name in ("good", "bad"):
        assert main(["compare", str(tmp_path / "full"), str(tmp_path / name), "--out",
                     str(tmp_path / f"cmp-{name}")]) == 0
    good = json.loads((tmp_path / "cmp-good" / "comparison.json").read_text())
    bad = json.loads((tmp_path / "cmp-bad" / "comparison.json").read_text())
    scatter = good["ensemble"]["histories"]["full_scatter"]["fe_node"]
    rms = np.sqrt(np.mean(SHAPE**2))
    expected = [abs(0.9 - 1.05) / 1.05 * rms, 0.0, abs(1.1 - 0.95) / 0.95 * rms]
    # sensors.csv keeps 10 significant digits: 5e-10 relative per value
    assert scatter["nrms_leave_one_out"] == pytest.approx(expected, abs=2e-9)
    verdict = good["ensemble"]["within_full_scatter"]["sensors"]["fe_node"]["nrms"]
    assert verdict["within"] and not verdict["weak"] and verdict["n_full"] == 3
    assert not bad["ensemble"]["within_full_scatter"]["sensors"]["fe_node"]["nrms"]["within"]
    assert set(good["pairs"]) == {"1", "2"}
    for png in ("ensemble_histories.png", "ensemble_damage_maps.png", "histories-seed-1.png"):
        assert (tmp_path / "cmp-good" / png).stat().st_size > 0


@pytest.mark.parametrize("change, message", [
    (dict(scale="medium"), "members differ in scale"),
    (dict(model="full"), "two full runs have seed 1"),
    (dict(end=2e-3), "members differ in duration: 1 ms"),
])
def test_members_that_cannot_be_compared_are_refused(tmp_path, capsys, change, message):
    member(tmp_path / "full" / "seed-1", "full", 1, 1.0)
    member(tmp_path / "full" / "seed-2", "full", 2, 1.0)
    member(tmp_path / "c", change.get("model", "coupled"), 1, 1.0, change.get("scale", "small"),
           end=change.get("end", T[-1]))
    args = ["compare", str(tmp_path / "full")]
    args += ["--full", str(tmp_path / "c")] if "model" in change else [str(tmp_path / "c")]
    args += ["--out", str(tmp_path / "cmp")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "cmp").exists()


def test_full_runs_at_another_time_step_are_judged_like_coupled_ones(tmp_path):
    """A full ensemble at another step (half the steps of twice the length: the same time) is
    the compared side; its figures land under "coupled"."""
    for seed, a in zip((1, 2, 3), (0.9, 1.0, 1.1)):
        member(tmp_path / "ref" / f"seed-{seed}", "full", seed, a)
        member(tmp_path / "step" / f"seed-{seed}", "full", seed, a * 1.01)
        spec_file = tmp_path / "step" / f"seed-{seed}" / "summary.json"
        summary = json.loads(spec_file.read_text())
        summary["spec"].update(steps=50, dt_safety=0.3)
        write_json(spec_file, summary)
    assert main(["compare", str(tmp_path / "ref"), str(tmp_path / "step"), "--out",
                 str(tmp_path / "cmp")]) == 0
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert r["pairs"]["1"]["sensors"]["de_zone"]["peak_ratio"] == pytest.approx(1.01, rel=1e-9)
    assert r["ensemble"]["within_full_scatter"]["sensors"]["fe_node"]["nrms"]["within"]


def test_a_verdict_needs_the_members_of_the_test(tmp_path, capsys):
    member(tmp_path / "f", "full", 1, 1.0)
    member(tmp_path / "c", "coupled", 1, 1.0)
    assert main(["compare", str(tmp_path / "f"), str(tmp_path / "c"), "--verdict", "--out",
                 str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and (
        "the equivalence test needs 2 same-seed pairs or 2 members of each model: got 1 full, "
        "1 coupled, 1 pairs") in err


def ensemble(folder, model, amplitudes):
    for seed, a in amplitudes.items():
        member(folder / f"seed-{seed}", model, seed, a)
    return folder


FULL = {1: 0.98, 2: 1.0, 3: 1.02, 4: 1.0}           # mean 1, pair differences known


def judged(tmp_path, coupled, *options):
    ensemble(tmp_path / "full", "full", FULL)
    ensemble(tmp_path / "coupled", "coupled", coupled)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "coupled"), "--out",
                 str(tmp_path / "cmp"), *options]) == 0
    return json.loads((tmp_path / "cmp" / "comparison.json").read_text())


def test_the_yardstick_finds_a_coupled_ensemble_like_the_full_one_equivalent(tmp_path, capsys):
    """Coupled members 1.01 × their full pair: every pair difference is 0.01 a_k (a_k / 1 of
    the full mean), peaks at the same sample: equivalent on every judged statistic, the
    interval the paired t interval of 0.01 a_k."""
    from scipy import stats
    r = judged(tmp_path, {s: 1.01 * a for s, a in FULL.items()})
    peak = r["judgement"]["qoi"]["deflection_x1.25"]["peak"]
    d = 0.01 * np.array(list(FULL.values()))
    half = stats.t.ppf(0.95, 3) * d.std(ddof=1) / 2
    assert peak["test"] == "paired" and peak["n_pairs"] == 4
    assert peak["interval"] == pytest.approx([d.mean() - half, d.mean() + half], abs=1e-9)
    assert all(v["verdict"] == "equivalent" for q in r["judgement"]["qoi"].values()
               for v in q.values())
    assert r["headline"].startswith("yardstick: equivalent on 23 of 23 (margins: peak 10%")
    crack = r["judgement"]["qoi"]["cracking_energy"]["total"]
    assert crack["difference"] == pytest.approx(0.01, abs=1e-12)
    assert r["cracking_map_correlation"] == pytest.approx(1.0)   # both maps 75:25 × a_k
    assert (tmp_path / "cmp" / "cracking_maps.png").stat().st_size > 0
    # the same-seed bias: each pair's peak 1.01 × the full one's
    assert peak["pair_bias"] == pytest.approx({str(s): 0.01 for s in FULL}, abs=1e-12)
    out = capsys.readouterr().out
    assert out.strip().splitlines()[-2] == r["headline"]
    assert out.strip().splitlines()[-3].startswith(
        "same-seed bias of the peaks (coupled / full − 1: mean [pairs' range]): impactor_z "
        "+1.0 % [+1.0, +1.0]")
    assert (tmp_path / "cmp" / "quantities.png").stat().st_size > 0
    assert (tmp_path / "cmp" / "profiles.png").stat().st_size > 0
    assert 'id="yardstick"' in (tmp_path / "cmp" / "report.html").read_text()


def test_the_yardstick_fails_a_biased_ensemble_and_names_every_failure(tmp_path):
    """Coupled members 1.2 × their pair: +20 % on every peak (and rms 0.2 rms(SHAPE) of the
    history), twice the margin: not equivalent, each named in the headline; their peak
    times agree."""
    r = judged(tmp_path, {s: 1.2 * a for s, a in FULL.items()})
    q = r["judgement"]["qoi"]
    assert q["reaction"]["peak"]["difference"] == pytest.approx(0.2, abs=1e-9)
    assert q["reaction"]["history"]["difference"] == pytest.approx(
        0.2 * np.sqrt(np.mean(SHAPE**2)), abs=1e-9)
    assert q["reaction"]["peak_time"]["verdict"] == "equivalent"
    failed = [f"{n} {s}" for n, v in q.items() for s in v if v[s]["verdict"] != "equivalent"]
    assert len(failed) == 16 and all(s in ("peak", "history", "total") for f in failed
                                     for s in [f.split()[-1]])
    assert all(f in r["headline"] for f in failed) and "NOT equivalent: " in r["headline"]


def test_the_yardstick_cannot_judge_a_wide_spread_nor_a_cut_window(tmp_path):
    """Pair differences of ± 0.4 (spread far past the 10 % margin): cannot judge, with the
    members it would need; and a member still rising at the window's end: not judged."""
    r = judged(tmp_path, {1: 1.38, 2: 0.6, 3: 1.42, 4: 0.6})
    peak = r["judgement"]["qoi"]["impactor_z"]["peak"]
    assert peak["verdict"] == "cannot judge" and peak["members_needed"] > 4
    assert f"impactor_z peak (needs {peak['members_needed']} members)" in r["headline"]
    rising = ensemble(tmp_path / "rising", "coupled", {s: 1.0 for s in FULL})
    values = qoi_shape()
    values[:, QOI.index("reaction")] = T / T[-1]
    write_quantities(rising / "seed-2" / QUANTITIES, QOI, T, values)
    assert main(["compare", str(tmp_path / "full"), str(rising), "--out",
                 str(tmp_path / "cut")]) == 0
    r = json.loads((tmp_path / "cut" / "comparison.json").read_text())
    assert r["judgement"]["qoi"]["reaction"] == {
        s: {"verdict": "not judged", "last_sample": ["coupled 2"]}
        for s in ("peak", "peak_time", "history")}
    assert "not judged: reaction (extreme at the window's end)" in r["headline"]


@pytest.mark.parametrize("margin", ["0", "-0.1", "nan", "inf"])
def test_a_margin_that_is_not_positive_is_one_line(tmp_path, capsys, margin):
    ensemble(tmp_path / "full", "full", FULL)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "full" / "seed-1"),
                 "--margin", margin, "--out", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert f"--margin: must be a finite number in (0, 1], got '{margin}'" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "cmp").exists()


def test_runs_without_the_quantities_or_with_other_definitions_are_refused(tmp_path, capsys):
    ensemble(tmp_path / "full", "full", FULL)
    ensemble(tmp_path / "c", "coupled", FULL)
    summary = tmp_path / "c" / "seed-3" / "summary.json"
    data = json.loads(summary.read_text())
    data["quantities"]["patch_radius_m"] = 0.2
    write_json(summary, data)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert "members differ in patch_radius_m: 0.1" in err and "0.2" in err
    (tmp_path / "full" / "seed-2" / QUANTITIES).unlink()
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "full"), "--verdict",
                 "--out", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "has no quantities.csv" in err
    assert not (tmp_path / "cmp").exists()


def test_a_peak_at_the_window_s_last_sample_is_warned(tmp_path, capsys):
    """SHAPE peaks mid-window: no warning; histories still rising when the window ends peak
    at its last sample."""
    member(tmp_path / "f", "full", 1, 1.0)
    member(tmp_path / "c", "coupled", 1, 1.0)
    assert main(["compare", str(tmp_path / "f"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "ok")]) == 0
    assert json.loads((tmp_path / "ok" / "comparison.json").read_text())["warnings"] == []
    rising = np.zeros((len(T), len(NAMES), 3))
    rising[:, 0, 2] = -T / T[-1]              # under_impact: still sinking at the end
    for run in ("f", "c"):
        write_sensors(tmp_path / run / "sensors.csv", NAMES, T, rising)
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "f"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "cmp")]) == 0
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert r["sensors"]["under_impact"]["peak_is_last_sample"] == ["full", "coupled"]
    assert r["sensors"]["de_zone"]["peak_is_last_sample"] == []     # zero: its peak is t = 0
    assert len(r["warnings"]) == 1 and "are the last sample (t = 1 ms)" in r["warnings"][0]
    assert "WARNING: seed 1: the peaks of under_impact (full, coupled)" in capsys.readouterr().out


def test_a_window_that_ends_before_the_impact_is_warned(tmp_path):
    """SHAPE's deflection rises back to 0 at the window's end: the event is over in every
    member; full seed 2's centre still sinking at the end: the window is too short for it."""
    r = judged(tmp_path, dict(FULL))
    assert not any("ends before the impact" in w for w in r["warnings"])
    assert set(r["judgement"]["event_end_s"]["full"]) == {"1", "2", "3", "4"}
    values = qoi_shape()
    values[:, QOI.index("deflection_x1.25")] = -T / T[-1]
    write_quantities(tmp_path / "full" / "seed-2" / QUANTITIES, QOI, T, values)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "coupled"), "--out",
                 str(tmp_path / "short")]) == 0
    r = json.loads((tmp_path / "short" / "comparison.json").read_text())
    assert r["judgement"]["event_end_s"]["full"]["2"]["slab_s"] is None
    assert [w for w in r["warnings"] if "ends before the impact" in w] == [
        "the window (1 ms) ends before the impact does: the impactor has stopped, rebounded or "
        "gone through in every full member; the slab's centre has not risen back by half its "
        "depth since then in full seeds 2 (run more --steps; a slab broken under the impact "
        "never rises)"]


def test_members_of_another_window_are_refused(tmp_path, capsys):
    """Coupled seeds 3, 4 of twice the steps (no same-seed pair to compare durations): their
    window, steps × dt_safety, is not the full members'; one line, nothing written."""
    ensemble(tmp_path / "full", "full", {1: 1.0, 2: 1.0})
    for seed in (3, 4):
        folder = member(tmp_path / "c" / f"seed-{seed}", "coupled", seed, 1.0, end=2e-3)
        summary = json.loads((folder / "summary.json").read_text())
        summary["spec"]["steps"] = 200
        write_json(folder / "summary.json", summary)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert "members differ in window (steps × dt_safety): 15.0 (full 1) vs 30.0 (coupled 3)" \
        in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "cmp").exists()


def test_runs_recorded_before_the_quantities_are_compared_on_their_sensors(tmp_path):
    """No run has quantities.csv: no yardstick, the sensors' figures as before; asked for a
    verdict, one line says why not."""
    for side, model in (("full", "full"), ("c", "coupled")):
        ensemble(tmp_path / side, model, FULL)
        for seed in FULL:
            (tmp_path / side / f"seed-{seed}" / QUANTITIES).unlink()
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "c"), "--out",
                 str(tmp_path / "cmp")]) == 0
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert "judgement" not in r and "within_full_scatter" in r["ensemble"]
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "c"), "--verdict", "--out",
                 str(tmp_path / "cmp2")]) == 2


def test_coupled_runs_of_another_zone_are_judged_on_the_quantities_alone(tmp_path, capsys):
    """Full members of the 0.6 m zone against coupled ones of a 1.0 m box, 1.01 × their pair:
    the QoIs (placed alike in every model) are judged as for runs of one zone, equivalent on
    all; the single-sphere sensors sit at other points, so neither their figures nor the
    scatter verdicts that read them are given, and a line says so. Without the QoIs, or
    against full runs kept elastic outside their zone, one line refuses."""
    ensemble(tmp_path / "full", "full", FULL)
    ensemble(tmp_path / "coupled", "coupled", {s: 1.01 * a for s, a in FULL.items()})
    for seed in FULL:
        path = tmp_path / "coupled" / f"seed-{seed}" / "summary.json"
        summary = json.loads(path.read_text())
        summary["spec"].update(de_zone=1.0, full_width=False)
        write_json(path, summary)
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "coupled"), "--out",
                 str(tmp_path / "cmp")]) == 0
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert r["headline"].startswith("yardstick: equivalent on 23 of 23")
    assert "ensemble" not in r and r["pairs"]["1"]["sensors"] == {}
    assert r["pairs"]["1"]["goals"] is None
    assert any("only the quantities of interest" in w for w in r["warnings"])
    assert not (tmp_path / "cmp" / "histories-seed-1.png").exists()
    assert (tmp_path / "cmp" / "quantities.png").stat().st_size > 0
    for side in ("full", "coupled"):
        for seed in FULL:
            (tmp_path / side / f"seed-{seed}" / QUANTITIES).unlink()
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "full"), str(tmp_path / "coupled"), "--out",
                 str(tmp_path / "cmp2")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "de_zone 0.6 vs 1.0" in err and "has no quantities.csv" in err
    for folder, model, key in (("elastic", "full", "elastic_outside"), ("c", "coupled", None)):
        path = member(tmp_path / folder, model, 1, 1.0) / "summary.json"
        summary = json.loads(path.read_text())
        summary["spec"].update({key: True} if key else {"de_zone": 1.0})
        write_json(path, summary)
    assert main(["compare", str(tmp_path / "elastic"), str(tmp_path / "c"),
                 "--out", str(tmp_path / "cmp3")]) == 2
    assert "kept its links elastic outside" in capsys.readouterr().err
