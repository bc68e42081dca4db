"""Ensemble statistics and verdicts on synthetic members whose figures are known in closed form.

Sensor "a": members (1 + e_i)·f, sensor "b": members f + d_i, with f = sin(2πt/T) sampled at
N points of one period: mean(f²) = 1/2 exactly and peak |f| = 1 (N divisible by 4).
"""
import json

import numpy as np
import pytest

from orchestrator import ensemble, verdicts

N, T = 40, 1e-3
E = {1: -0.1, 2: 0.0, 3: 0.1}          # full members, sensor a: scale offsets (mean 0)
D = {1: 0.0, 2: 0.03, 3: 0.09}         # full members, sensor b: additive offsets (mean 0.04)
CE, CD = {1: 0.2, 4: -0.05}, {1: 0.1, 4: 0.0}  # coupled members
SENSORS = ["a", "b"]
S2 = np.sqrt(2.0)


def f(t):
    return np.sin(2 * np.pi * t / T)


def member(e, d, n=N, extra=0):
    t = np.arange(n + extra) * T / n
    return t, np.column_stack([(1 + e) * f(t), f(t) + d])


def members():
    full = {s: member(E[s], D[s], extra=10 if s == 3 else 0) for s in E}   # seed 3 runs longer
    coupled = {s: member(CE[s], CD[s], n=2 * N, extra=40) for s in CE}       # finer, longer
    return full, coupled


@pytest.fixture(scope="module")
def stats():
    full, coupled = members()
    return ensemble.histories(full, coupled, SENSORS)


def test_time_base_is_the_common_window(stats):
    assert stats["n_times"] == N and stats["time_window_s"] == [0.0, (N - 1) * T / N]
    assert stats["full_seeds"] == [1, 2, 3] and stats["coupled_seeds"] == [1, 4]
    assert stats["paired_seeds"] == [1]


def test_full_scatter_scaled_copies(stats):
    a = stats["full_scatter"]["a"]
    e = np.array([E[s] for s in (1, 2, 3)])
    assert a["mean_peak"] == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(a["peaks"], 1 + e, atol=1e-14)
    np.testing.assert_allclose(a["peak_range"], [0.9, 1.1], atol=1e-14)
    np.testing.assert_allclose(a["nrms"], np.abs(e) / S2, atol=1e-14)
    # the others' mean is (1 - e_i/2) f: deviation 1.5 e_i f = n/(n-1) × the leave-in one
    np.testing.assert_allclose(a["nrms_leave_one_out"], 1.5 * np.abs(e) / S2 / (1 - e / 2),
                               atol=1e-14)
    np.testing.assert_allclose(a["peak_ratio_leave_one_out"], (1 + e) / (1 - e / 2), atol=1e-14)


def test_full_scatter_offsets(stats):
    b = stats["full_scatter"]["b"]
    d = np.array([D[s] for s in (1, 2, 3)])
    others = (d.sum() - d) / 2
    assert b["mean_peak"] == pytest.approx(1.04, abs=1e-14)
    np.testing.assert_allclose(b["nrms"], np.abs(d - 0.04) / 1.04, atol=1e-14)
    np.testing.assert_allclose(b["nrms_leave_one_out"], np.abs(d - others) / (1 + others),
                               atol=1e-14)
    np.testing.assert_allclose(b["peak_ratio_leave_one_out"], (1 + d) / (1 + others), atol=1e-14)


def test_coupled_against_the_mean_and_paired(stats):
    c, cd = np.array([CE[1], CE[4]]), np.array([CD[1], CD[4]])
    a, b = stats["coupled_vs_full_mean"]["a"], stats["coupled_vs_full_mean"]["b"]
    np.testing.assert_allclose(a["nrms"], np.abs(c) / S2, atol=1e-14)
    np.testing.assert_allclose(a["peak_ratio"], 1 + c, atol=1e-14)
    np.testing.assert_allclose(b["nrms"], np.abs(cd - 0.04) / 1.04, atol=1e-14)
    np.testing.assert_allclose(b["peak_ratio"], (1 + cd) / 1.04, atol=1e-14)
    pa, pb = stats["paired"]["a"], stats["paired"]["b"]
    np.testing.assert_allclose(pa["nrms"], [0.3 / S2 / 0.9], atol=1e-14)
    np.testing.assert_allclose(pa["peak_ratio"], [1.2 / 0.9], atol=1e-14)
    np.testing.assert_allclose(pb["nrms"], [0.1], atol=1e-14)
    np.testing.assert_allclose(pb["peak_ratio"], [1.1], atol=1e-14)


def test_verdict_per_sensor(stats):
    v = verdicts.within_full_scatter(stats)["sensors"]
    # a: coupled 0.2/√2 = 0.141 against the largest leave-one-out 0.15/√2/0.95 = 0.112
    assert v["a"]["nrms"]["coupled_max"] == pytest.approx(0.2 / S2, abs=1e-14)
    assert v["a"]["nrms"]["full_leave_one_out_max"] == pytest.approx(0.15 / S2 / 0.95, abs=1e-14)
    assert not v["a"]["nrms"]["within"]
    # b: coupled 0.06/1.04 = 0.058 against 0.075/1.015 = 0.074 (member 3)
    assert v["b"]["nrms"]["full_leave_one_out_max"] == pytest.approx(0.075 / 1.015, abs=1e-14)
    assert v["b"]["nrms"]["within"] and not v["b"]["nrms"]["weak"]
    # peaks, b: coupled |1.1/1.04 - 1| = 0.0577 against |1.09/1.015 - 1| = 0.0739
    assert v["b"]["peak"]["coupled_max"] == pytest.approx(0.06 / 1.04, abs=1e-14)
    assert v["b"]["peak"]["within"]
    # a: coupled 0.2 against |1.1/0.95 - 1| = 0.158
    assert not v["a"]["peak"]["within"]


def test_a_null_prediction_is_measured_against_the_scatter(stats):
    """A history that stays at zero lies rms(mean) / peak(mean) from the mean (a: f, 1/√2; b:
    f + 0.04 over whole periods, √(1/2 + 0.04²) / 1.04) and |0 - 1| = 1 in peak and damage.
    Members 0.2 f and 3 f differ by more than that: no coupled model can be judged by them."""
    assert stats["full_scatter"]["a"]["null_nrms"] == pytest.approx(1 / S2, abs=1e-14)
    assert stats["full_scatter"]["b"]["null_nrms"] == pytest.approx(np.sqrt(0.5 + 0.04 ** 2)
                                                                    / 1.04, abs=1e-14)
    v = verdicts.within_full_scatter(stats)["sensors"]
    assert v["a"]["nrms"]["null_within"] is False and v["a"]["peak"]["null_within"] is False
    t = np.arange(N) * T / N
    wide = {1: (t, 0.2 * f(t)[:, None]), 2: (t, 3 * f(t)[:, None])}
    w = ensemble.histories(wide, {5: (t, f(t)[:, None])}, ["a"])
    assert w["full_scatter"]["a"]["null_nrms"] == pytest.approx(1 / S2, abs=1e-14)
    vw = verdicts.within_full_scatter(w)["sensors"]["a"]
    assert vw["nrms"]["full_leave_one_out_max"] == pytest.approx(2.8 / 0.2 / S2, abs=1e-12)
    assert vw["nrms"]["null_within"] and vw["peak"]["null_within"]   # peaks: 3 / 0.2 - 1 = 14
    d = ensemble.damage({s: {"damaged_volume_m3": v, "broken_links": 10}
                         for s, v in ((1, 1.0), (2, 1.0), (3, 5.0))},
                        {1: {"damaged_volume_m3": 2.0, "broken_links": 10}})
    dv = verdicts.damage_within_full_scatter(d)
    assert dv["damaged_volume_m3"]["full_leave_one_out_max"] == pytest.approx(4.0, abs=1e-14)
    assert dv["damaged_volume_m3"]["null_within"] and not dv["broken_links"]["null_within"]


def test_leave_one_out_is_not_the_leave_in_figure():
    """Two members ±δ f about f: each lies δ/√2 from their mean but 2δ/√2/(1 ∓ δ) from the other.
    A coupled member 1.5 δ away is outside the leave-in spread and inside the leave-one-out one."""
    delta = 0.1
    full = {1: member(-delta, 0), 2: member(delta, 0)}
    coupled = {7: member(1.5 * delta, 0)}
    s = ensemble.histories(full, coupled, SENSORS)
    np.testing.assert_allclose(s["full_scatter"]["a"]["nrms"], [delta / S2] * 2, atol=1e-14)
    np.testing.assert_allclose(s["full_scatter"]["a"]["nrms_leave_one_out"],
                               [2 * delta / S2 / (1 + delta), 2 * delta / S2 / (1 - delta)],
                               atol=1e-14)
    v = verdicts.within_full_scatter(s)["sensors"]["a"]["nrms"]
    assert v["within"] and v["weak"] and v["n_full"] == 2


def test_damage_figures_and_verdict():
    full = {1: {"damaged_volume_m3": 0.03, "broken_links": 5000},
            2: {"damaged_volume_m3": 0.04, "broken_links": 6000},
            3: {"damaged_volume_m3": 0.05, "broken_links": 7000}}
    coupled = {1: {"damaged_volume_m3": 0.06, "broken_links": 5500},
               4: {"damaged_volume_m3": 0.045, "broken_links": 6500}}
    d = ensemble.damage(full, coupled)
    vol = d["full"]["damaged_volume_m3"]
    assert vol["mean"] == pytest.approx(0.04, abs=1e-16)
    assert vol["range"] == [0.03, 0.05] and vol["members"] == [0.03, 0.04, 0.05]
    np.testing.assert_allclose(vol["ratio_leave_one_out"], [0.03 / 0.045, 1.0, 0.05 / 0.035],
                               atol=1e-14)
    np.testing.assert_allclose(d["coupled_vs_full_mean"]["damaged_volume_m3"]["ratio"],
                               [1.5, 1.125], atol=1e-14)
    np.testing.assert_allclose(d["coupled_vs_full_mean"]["broken_links"]["ratio"],
                               [5500 / 6000, 6500 / 6000], atol=1e-14)
    np.testing.assert_allclose(d["paired"]["damaged_volume_m3"]["ratio"], [2.0], atol=1e-14)
    np.testing.assert_allclose(d["paired"]["broken_links"]["ratio"], [1.1], atol=1e-14)
    stats = ensemble.histories(*members(), SENSORS)
    v = verdicts.within_full_scatter(stats, d)["damage"]
    assert v["damaged_volume_m3"]["coupled_max"] == pytest.approx(0.5, abs=1e-14)
    assert v["damaged_volume_m3"]["full_leave_one_out_max"] == pytest.approx(0.05 / 0.035 - 1,
                                                                             abs=1e-14)
    assert not v["damaged_volume_m3"]["within"]
    # links: coupled 6500/6000 - 1 = 0.083 against 7000/5500 - 1 = 0.273
    assert v["broken_links"]["coupled_max"] == pytest.approx(500 / 6000, abs=1e-14)
    assert v["broken_links"]["full_leave_one_out_max"] == pytest.approx(1500 / 5500, abs=1e-14)
    assert v["broken_links"]["within"]
    goals = verdicts.ensemble_goals(stats, d)
    json.dumps([d, stats, v, goals])  # plain types, ready for comparison.json
    # coupled seed 4 against the mean: nRMS 0.035 and 0.038, peaks 0.95 and 0.96, volume 1.125
    assert goals["coupled_vs_full_mean"][1] == {"peaks_within_10_percent": True,
                                                "history_nrms_at_most_15_percent": True,
                                                "damaged_volume_within_15_percent": True}
    # coupled seed 1 against full seed 1: peak ratio 1.33, nRMS 0.236, volume 2
    assert not any(goals["paired"][0].values())


def test_no_damage_anywhere_is_an_exact_agreement_that_says_nothing():
    none = {"damaged_volume_m3": 0.0, "broken_links": 0}
    d = ensemble.damage({1: none, 2: none, 3: none}, {1: none})
    v = verdicts.damage_within_full_scatter(d)["damaged_volume_m3"]
    assert v["within"] and v["null_within"] and v["coupled_max"] == 0.0
    d = ensemble.damage({1: none, 2: none}, {1: {"damaged_volume_m3": 1e-6, "broken_links": 1}})
    assert not verdicts.damage_within_full_scatter(d)["broken_links"]["within"]


def test_absolute_goals():
    g = verdicts.absolute_goals({"a": 0.149, "b": 0.02}, {"a": 1.09, "b": 0.91}, 0.86)
    assert all(g.values())
    g = verdicts.absolute_goals({"a": 0.151, "b": None}, {"a": 1.11, "b": 1.0}, 1.16)
    assert not any(g.values())
    assert not verdicts.absolute_goals({"a": 0.1}, {"a": None}, None)["peaks_within_10_percent"]


def test_paired_map_correlation_follows_the_slab_index():
    rng = np.random.default_rng(0)
    full_index = rng.permutation(50) + 100
    full_damage = rng.random(50)
    pick = rng.choice(50, 20, replace=False)
    coupled_index, coupled_damage = full_index[pick], 2 * full_damage[pick] + 0.1
    assert ensemble.paired_map_correlation(full_index, full_damage, coupled_index,
                                           coupled_damage) == pytest.approx(1.0, abs=1e-12)
    mask = np.arange(20) < 10
    flipped = np.where(mask, 1 - full_damage[pick], 0.0)
    assert ensemble.paired_map_correlation(full_index, full_damage, coupled_index, flipped,
                                           mask) == pytest.approx(-1.0, abs=1e-12)
    with pytest.raises(ValueError, match="not in the full packing"):
        ensemble.paired_map_correlation(full_index, full_damage, [5, 100 + pick[0]], [0.1, 0.2])


def test_plan_grid_weighted_means():
    pos = np.array([[0.05, 0.05, 0], [0.08, 0.02, 1], [0.15, 0.05, 0], [0.25, 0.15, 0]])
    grid, x, y = ensemble.plan_grid(pos, [1.0, 0.0, 0.5, 0.2], [1.0, 3.0, 1.0, 2.0],
                                    (0, 0), (0.3, 0.2), 0.1)
    np.testing.assert_allclose(x, [0.05, 0.15, 0.25])
    np.testing.assert_allclose(y, [0.05, 0.15])
    expected = np.array([[0.25, np.nan], [0.5, np.nan], [np.nan, 0.2]])
    np.testing.assert_array_equal(np.isnan(grid), np.isnan(expected))
    np.testing.assert_allclose(grid[~np.isnan(grid)], expected[~np.isnan(expected)])


def _cells_member(field, counts):
    """Spheres at the centres of a 4 × 3 grid of 0.1 m cells, counts[i] spheres in cell i."""
    cx, cy = np.meshgrid(0.05 + 0.1 * np.arange(4), 0.05 + 0.1 * np.arange(3), indexing="ij")
    centres = np.column_stack([cx.ravel(), cy.ravel(), np.zeros(12)])
    rows = np.repeat(np.arange(12), counts)
    return centres[rows], field.ravel()[rows], np.ones(rows.size)


def test_mean_damage_maps_correlate_over_the_cells_both_hold():
    g = np.linspace(0, 1, 12).reshape(4, 3) ** 2
    full = {1: _cells_member(g, [1] * 12), 2: _cells_member(g, [2, 1] * 6)}
    zone = [0, 0, 0] + [1] * 6 + [0, 0, 0]          # the coupled spheres: the middle cells
    coupled = {1: _cells_member(1 - 0.5 * g, zone), 5: _cells_member(1 - 0.5 * g, zone)}
    maps = ensemble.mean_damage_maps(full, coupled, (0, 0), (0.4, 0.3), 0.1)
    np.testing.assert_allclose(maps["full"], g, atol=1e-15)
    assert np.isnan(maps["coupled"][[0, 3]]).all() and np.isfinite(maps["coupled"][1:3]).all()
    assert maps["correlation"] == pytest.approx(-1.0, abs=1e-12)


def test_refusals_name_the_key_and_values():
    with pytest.raises(ValueError, match=r"members differ in scale: 'small' \(full 1\) vs "
                                         r"'medium' \(coupled 2\)"):
        ensemble.check_same_kind({"full 1": {"case": "slab", "scale": "small", "steps": 3300},
                                  "coupled 2": {"case": "slab", "scale": "medium", "steps": 3300}})
    with pytest.raises(ValueError, match=r"members differ in steps: 3300 \(a\) vs 4400 \(b\)"):
        ensemble.check_same_kind({"a": {"steps": 3300}, "b": {"steps": 4400}})
    with pytest.raises(ValueError, match=r"members differ in case: 'slab' \(a\) vs None \(b\)"):
        ensemble.check_same_kind({"a": {"case": "slab"}, "b": {}})
    ensemble.check_same_kind({"a": {"case": "slab", "steps": 1}, "b": {"steps": 1, "case": "slab"}})


def test_refusals_of_too_few_members_and_bad_histories():
    full, coupled = members()
    one = ensemble.histories({1: full[1]}, coupled, SENSORS)
    assert one["full_scatter"]["a"]["nrms_leave_one_out"] is None
    with pytest.raises(ValueError, match="needs at least 2 full runs .seeds., got 1") as err:
        verdicts.within_full_scatter(one)
    assert "\n" not in str(err.value)
    with pytest.raises(ValueError, match="needs a coupled run"):
        verdicts.within_full_scatter(ensemble.histories(full, {}, SENSORS))
    late = (full[2][0] + 2 * T, full[2][1])
    with pytest.raises(ValueError, match="share no time window"):
        ensemble.histories({1: full[1], 2: late}, {}, SENSORS)
    with pytest.raises(ValueError, match=r"coupled run of seed 4: history of shape \(120, 1\), "
                                         r"expected \(120, 2\)"):
        ensemble.histories(full, {1: coupled[1], 4: (coupled[4][0], coupled[4][1][:, :1])},
                           SENSORS)


def test_plots_write_pngs(tmp_path):
    from orchestrator.ensemble_plots import plot_histories, plot_mean_damage_maps
    full, coupled = members()
    plot_histories(tmp_path / "h.png", full, coupled, SENSORS)
    g = np.linspace(0, 1, 12).reshape(4, 3)
    maps = ensemble.mean_damage_maps({1: _cells_member(g, [1] * 12)},
                                     {1: _cells_member(g, [1] * 12)}, (0, 0), (0.4, 0.3), 0.1)
    plot_mean_damage_maps(tmp_path / "d.png", maps, 1, 1)
    for name in ("h.png", "d.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
