"""The bench's derived figures and goal verdicts on made-up worker output (no timing here)."""
import pytest

from bench.report import derive, markdown


def worker_output(n, bridging, yade, fe=0.0, coupling=0.0, output=0.0, peak_gb=0.5, impact=1.5):
    timing = {"median_s": yade + fe + coupling, "wall_median_s": yade + fe + coupling,
              "split_median_s": {"yade": yade, "fe": fe, "coupling": coupling, "output": 0.0}}
    r = {"n_spheres": n, "n_bridging_spheres": bridging, "build_s": 10.0, "timing": timing,
         "output": {"per_step_s": output}, "peak_rss_bytes": peak_gb * 1e9, "dt": 1e-6,
         "timing_impact": {"median_s": impact * (yade + fe + coupling)}}
    if bridging:
        r["variants"] = {"diagonal": {"coupling_s": coupling, "guarded_rows": 3},
                         "full": {"coupling_s": 2 * coupling, "factorisation_s": 0.5,
                                  "system_size": 300}}
        r["coupling_parts"] = {k: 1e-4 for k in ("read_s", "multipliers_s", "write_s",
                                                 "correct_and_write_spheres_s", "correct_fe_s",
                                                 "exchange_meter_s", "api_read_s", "api_write_s")}
        r["coupling_parts"]["direct_memory_exchange"] = True
    return r


def raw(coupled_peak_gb):
    # full: 100,000 spheres, 1.0 s/step; coupled: 20,000 spheres (ratio 5), 0.25 s/step of
    # which coupling 0.03 s (12 %) and FE 0.01 s (4 %); speed-up 4 = 0.8 x the ratio
    return {"scales": {"paper": {
        "full": worker_output(100_000, 0, yade=0.99, output=0.01, peak_gb=2.4, impact=2.0),
        "coupled": worker_output(20_000, 8_000, yade=0.20, fe=0.01, coupling=0.03,
                                 output=0.01, peak_gb=coupled_peak_gb)}},
        "threads": {"1": {"scale": "medium", "s_per_step": 0.2, "n_spheres": 1},
                    "2": {"scale": "medium", "s_per_step": 0.125, "n_spheres": 1}}}


def test_derived_figures_and_goal_verdicts():
    d = derive(raw(coupled_peak_gb=1.2))
    s = d["per_scale"]["paper"]
    assert s["sphere_count_ratio"] == pytest.approx(5.0)
    assert s["speedup_per_step"] == pytest.approx(4.0)
    assert s["speedup_over_ratio"] == pytest.approx(0.8)
    assert s["coupling_fraction"] == pytest.approx(0.12)
    assert s["fe_fraction"] == pytest.approx(0.04)
    assert s["coupling_per_bridging_sphere_s"]["full"] == pytest.approx(2 * 0.03 / 8000)
    assert s["full"]["projected_100k_steps_s"] == pytest.approx(1e5)
    # impact window: full 0.99 x 2 + 0.01, coupled 0.24 x 1.5 + 0.01 (output amortised alike)
    assert s["full"]["impact_step_s"] == pytest.approx(1.99)
    assert s["speedup_per_step_impact"] == pytest.approx(1.99 / 0.37)
    assert s["coupled"]["projected_100k_steps_impact_s"] == pytest.approx(3.7e4)
    assert s["coupled"]["s_per_simulated_ms"]["impact"] == pytest.approx(0.37e3)
    assert d["thread_speedup"]["2"] == pytest.approx(1.6)
    verdicts = [g["met"] for g in d["goals"]]
    # coupling share, FE share, speed-up, coupled 100k steps (10.3 h), speed-up in the impact
    # (1.99 / 0.37 = 5.4x < 10x), full memory, coupled memory, bridging share (8,000 of
    # 20,000: 40 %, at the bound)
    assert verdicts == [False, True, False, False, False, True, False, True]


def goal(d, start):
    return next(g for g in d["goals"] if g["goal"].startswith(start))


def test_the_paper_speedup_goal_is_judged_in_the_impact_window():
    """The default paper coupled model at 12,500 spheres (1,500 bridging): 0.095 s per step
    before contact, x 1.5 in the impact (+ 0.005 s output): the full model's 1.0 and 1.99 s give
    10x and 13.49x; 100,000 impact steps 4.1 h."""
    r = raw(coupled_peak_gb=0.5)
    r["scales"]["paper"]["coupled"] = worker_output(12_500, 1_500, yade=0.08, fe=0.005,
                                                    coupling=0.01, output=0.005)
    d = derive(r)
    assert d["per_scale"]["paper"]["speedup_per_step_impact"] == pytest.approx(
        1.99 / (0.095 * 1.5 + 0.005))
    speedup = goal(d, "paper-scale coupled model >= 10x per step (impact window)")
    assert speedup["met"]
    assert speedup["figure"] == "13.49x (10.00x before contact) for 8.00x fewer spheres"
    hours = goal(d, "coupled 100,000 steps <= 1.5 h on one core")
    assert hours["figure"] == "4.10 h" and hours["met"] is False
    share = goal(d, "bridging share of the default coupled model's spheres <= 40%")
    assert share["figure"] == "12.0%" and share["met"] is True
    r["scales"]["paper"]["coupled"]["n_bridging_spheres"] = 6_000      # 48 %: over 40 %
    share = goal(derive(r), "bridging share of the default coupled model's spheres <= 40%")
    assert share["figure"] == "48.0%" and share["met"] is False


def test_the_fe_with_damage_is_judged_in_the_impact_window():
    """The FE with damage: 0.02 s of a 0.30 s step in the impact window (6.7 %, under 10 %),
    whatever its share right after the build."""
    r = raw(coupled_peak_gb=0.5)
    damage = worker_output(20_000, 8_000, yade=0.20, fe=0.05, coupling=0.03)
    damage["timing_impact"] = {"median_s": 0.30, "split_median_s": {
        "yade": 0.25, "fe": 0.02, "coupling": 0.03, "output": 0.0}}
    r["scales"]["paper"]["coupled_damage"] = damage
    d = derive(r)
    assert d["per_scale"]["paper"]["fe_damage_fraction"] == pytest.approx(0.02 / 0.30)
    assert goal(d, "FE with damage < 10% of the coupled step")["met"]
    table = markdown(dict(d, raw=r, mode="full", date_utc="today", bench_wall_s=60.0,
                          machine_at_start={"cpus": 2, "load_average": (0.1, 0, 0)},
                          machine_at_end={"load_average": (0.2, 0, 0)}))
    assert "| paper | coupled, FE damage | 20,000 | 8,000 |" in table


def test_a_conversion_is_judged_in_steps_of_the_grown_model():
    """0.6 s for a conversion whose grown model steps in 0.05 s: 12 steps, over the 10 of the
    goal; 0.4 s: 8, within it; both in the table. A larger zone's conversion is judged too:
    3 s at 0.4 s a step (8 steps) leaves the verdict to the first, 4.4 s (11) misses."""
    r = raw(coupled_peak_gb=0.5)
    conversion = lambda seconds, step, start: {
        "start_zone_m": start, "spheres_before": 12_000, "spheres_after": 20_000,
        "conversion_s": seconds, "build_wall_s": 0.4, "carry_wall_s": 0.1, "wall_s": seconds,
        "grown_step_s": step, "conversion_steps": seconds / step}
    for seconds, large, met in ((0.6, 3.0, False), (0.4, 3.0, True), (0.4, 4.4, False)):
        r["scales"]["paper"]["conversion"] = conversion(seconds, 0.05, 0.5)
        r["scales"]["paper"]["conversion_large"] = conversion(large, 0.4, 1.5)
        d = derive(r)
        g = goal(d, "a conversion of the grown zone <= 10 steps")
        steps, steps_large = round(seconds / 0.05), round(large / 0.4)
        assert g["met"] is met and g["figure"] == (
            f"{steps} steps ({seconds:.2f} s, 12,000 to 20,000 spheres); "
            f"{steps_large} steps ({large:.2f} s, 12,000 to 20,000 spheres)")
        table = markdown(dict(d, raw=r, mode="full", date_utc="today", bench_wall_s=60.0,
                              machine_at_start={"cpus": 2, "load_average": (0.1, 0, 0)},
                              machine_at_end={"load_average": (0.2, 0, 0)}))
        assert (f"| paper | 0.5 | 12,000 | 20,000 | {seconds:.2f} | 0.40 | 0.10 | 50.00 | "
                f"{steps} |") in table
        assert (f"| paper | 1.5 | 12,000 | 20,000 | {large:.2f} | 0.40 | 0.10 | 400.00 | "
                f"{steps_large} |") in table


def test_goals_without_paper_scale_are_labelled_and_memory_not_judged():
    r = raw(coupled_peak_gb=0.5)
    r["scales"]["medium"] = r["scales"].pop("paper")
    d = derive(r)
    assert all("medium" in g["goal"] for g in d["goals"][:3])
    assert [g["met"] for g in d["goals"][4:7]] == [None, None, None]
    assert goal(d, "paper-scale coupled model >= 10x")["figure"] == "not measured (medium: 5.38x)"
    table = markdown(dict(d, raw=r, mode="quick", date_utc="today", bench_wall_s=60.0,
                          machine_at_start={"cpus": 2, "load_average": (0.1, 0, 0)},
                          machine_at_end={"load_average": (0.2, 0, 0)}))
    assert "| medium | coupled | 20,000 | 8,000 |" in table


def test_quick_regression_check_against_the_reference(tmp_path):
    import json
    from bench.run import REGRESSION, regression

    def medium(coupled, full):
        return {"scales": {"medium": {"coupled": worker_output(15_000, 6_000, yade=coupled),
                                      "full": worker_output(25_000, 0, yade=full)}}}
    reference = tmp_path / "results.json"
    reference.write_text(json.dumps({"raw": medium(0.060, 0.080)}))
    lines, slower = regression(medium(0.060 * REGRESSION * 0.98, 0.080), reference)
    assert not slower and len(lines) == 2
    assert f"= {REGRESSION * 0.98:.3f} x results.json's (full model 1.000 x)" in lines[0]
    lines, slower = regression(medium(0.060 * REGRESSION * 1.01, 0.080), reference)
    assert slower
    lines, slower = regression(medium(0.06, 0.08), tmp_path / "none.json")
    assert not slower and "no reference medium figures" in lines[0]
