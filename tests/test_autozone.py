"""The DE zone the run finds for itself: exact trips of the FE-stress indicator on stretched
FE blocks, the growth and the limit of the search, the slab's checks of its options, and the
post-run check of the run's peak FE stress."""
import numpy as np
import pytest

from fenicsx_side.cells import box_mesh_without_cells
from fenicsx_side.model import ElasticModel
from orchestrator.coupling.cells import CellGrid
from orchestrator.run.autozone import TripLevels, Tripped, Watch, find_zone

E, NU, RHO, FT = 30e9, 0.2, 2400.0, 3e6
P0, P1, N = (0.0, 0.0, 0.0), (1.2, 0.8, 0.2), (6, 4, 1)
BAND = np.zeros((6, 4), bool)     # zone (0, 0) and its one-layer band
BAND[:2, :2] = True


class StretchedBlock:
    """A model of the run loop's kind without spheres: an FE block (the grid less the zone,
    with the zone's one-layer bridging band) whose step n imposes the displacement
    n · field(nodes)."""

    def __init__(self, zone, field):
        from orchestrator.coupling.bridging import Bridging
        removed = np.repeat(zone[:, :, None], N[2], axis=2)
        self.fe = ElasticModel(box_mesh_without_cells(P0, P1, N, removed), E, NU, RHO)
        self.bridging = Bridging(CellGrid(P0, P1, N).zone(zone), 1, 0.2) if zone.any() else None
        self.bridge_index = np.empty(0, int)
        self.parts = type("Parts", (), {"inside_step": False})()
        self.spheres = type("NoSpheres", (), {"ref_pos": np.empty((0, 3))})()
        self.seconds = {"yade": 0.0}
        self.field = field(self.fe.nodes).ravel()
        self.n = 0

    def sphere_count(self):
        return 0

    def step(self):
        self.n += 1
        self.fe.u = self.n * self.field


def uniaxial(strain):
    """u = ε (x, −ν y, −ν z): uniaxial stress σxx = E ε, exact on Q1 cells."""
    return lambda x: strain * np.column_stack([x[:, 0], -NU * x[:, 1], -NU * x[:, 2]])


def steps(model, k, n=30):
    for _ in range(n):
        model.step()
    return {"attempt": k}


def test_uniaxial_stretch_trips_at_the_first_check_past_ft():
    """σ1 = E · n · δ: with δ = 0.7e-5 and a check every 3 steps, σ1 = 2.52 MPa at step 12 and
    3.15 MPa at step 15 (ft = 3 MPa): the trip is at step 15 and flags every FE cell outside
    the band (the zone is cell (0, 0), its band (1, 0), (0, 1), (1, 1): 20 of the 23)."""
    grid = CellGrid(P0, P1, N)
    zone = np.zeros(grid.shape, bool)
    zone[0, 0] = True
    m = StretchedBlock(zone, uniaxial(0.7e-5))
    watch = Watch(m, grid, FT, TripLevels(stress=1.0, stress_every=3))
    with pytest.raises(Tripped) as e:
        steps(m, 0)
    assert e.value.step == 15 and watch.steps == 15
    assert watch.peak_stress == pytest.approx(E * 15 * 0.7e-5, rel=1e-12)
    assert "σ1 3.15 MPa ≥ 1 × ft in 20 cells" in e.value.indicator
    assert np.array_equal(e.value.cells, ~BAND & ~zone)
    # the same stretch below the level never trips
    m = StretchedBlock(zone, uniaxial(0.6e-5 / 30))
    Watch(m, grid, FT, TripLevels(stress=1.0, stress_every=3))
    assert steps(m, 0) == {"attempt": 0}


def test_an_fe_that_damages_trips_on_its_damage_not_its_stress():
    """The same stretch on an FE with the damage law (ft 3 MPa, box cells of 0.2 m): D(n δ) of
    the law's curve; with δ = 1e-4 and a check every 2 steps the first check with D ≥ 0.9 is
    found from the law itself, and every cell outside the band is flagged; stresses past ft do
    not trip."""
    from fenicsx_side.damage_law import ConcreteDamage
    from fenicsx_side.damaged import DamageModel
    law = ConcreteDamage(E, NU, FT, 30e6, 100.0, 30e3)
    grid = CellGrid(P0, P1, N)
    zone = np.zeros(grid.shape, bool)
    zone[0, 0] = True
    m = StretchedBlock(zone, uniaxial(1e-4))
    removed = np.repeat(zone[:, :, None], N[2], axis=2)
    m.fe = DamageModel(box_mesh_without_cells(P0, P1, N, removed), law, RHO)
    step = m.step

    def damaging_step():
        step()
        m.fe.update_damage()
    m.step = damaging_step
    ef = law.softening_strain(0.2)
    expected = next(n for n in range(2, 40, 2) if law.damage(n * 1e-4, ef) >= 0.9)
    watch = Watch(m, grid, FT, TripLevels(stress=1.0, stress_every=2))
    with pytest.raises(Tripped) as e:
        steps(m, 0)
    assert e.value.step == expected
    assert watch.peak_damage == pytest.approx(law.damage(expected * 1e-4, ef), rel=1e-9)
    assert "FE damage" in e.value.indicator and "in 20 cells" in e.value.indicator
    assert np.array_equal(e.value.cells, ~BAND & ~zone)


def test_the_band_cells_stress_does_not_trip():
    """u_x = ε min(x, 0.4), the zone cell (0, 0): the cells with x < 0.4 (i = 0, 1) carry the
    same stress σ1 = (λ + 2μ) ε n; at the first step past ft only those outside the band trip:
    (0, 2), (0, 3), (1, 2), (1, 3), not the band's (1, 0), (0, 1), (1, 1)."""
    grid = CellGrid(P0, P1, N)
    zone = np.zeros(grid.shape, bool)
    zone[0, 0] = True
    m = StretchedBlock(zone, lambda x: np.column_stack([1.1e-5 * np.minimum(x[:, 0], 0.4),
                                                        0 * x[:, :2]]))
    Watch(m, grid, FT, TripLevels(stress=1.0, stress_every=1))
    with pytest.raises(Tripped) as e:
        steps(m, 0)
    lam_2mu = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    assert e.value.step == int(np.ceil(FT / (lam_2mu * 1.1e-5)))
    assert sorted(map(tuple, np.argwhere(e.value.cells).tolist())) == [(0, 2), (0, 3), (1, 2),
                                                                       (1, 3)]


def test_a_trip_at_the_runs_last_step_converts_nothing():
    """The stretch of test_uniaxial_stretch_trips_at_the_first_check_past_ft trips at step 15:
    a zone grown during a run of 15 steps does not convert there (no step follows), one of
    18 steps does."""
    from orchestrator.run.grow import GrowingModel
    grid = CellGrid(P0, P1, N)
    zone = np.zeros(grid.shape, bool)
    zone[0, 0] = True
    for last, converted in ((15, []), (18, [15])):
        m = GrowingModel(lambda mask, grown_from=None, earlier=(): StretchedBlock(
            mask, uniaxial(0.7e-5)), grid, zone, np.ones(grid.shape, bool), FT,
            TripLevels(stress=1.0, stress_every=3), tol=1e-9, log=None, last_step=last)
        asked = []
        m.grow = lambda t: asked.append(t.step)
        steps(m, 0, 15)
        assert asked == converted


def test_zone_grows_over_the_flagged_cells_and_margin_then_runs_clean():
    """u_x = ε max(x − 0.8, 0): only the cells beyond x = 0.8 (i = 4, 5) carry stress,
    σ1 = (λ + 2μ) ε. The first attempt trips there; the zone grows by those cells and one
    cell around (i ≥ 3); the next FE mesh has no cell beyond x = 0.8 and runs clean."""
    grid = CellGrid(P0, P1, N)
    start = np.zeros(grid.shape, bool)
    start[0, 0] = True
    kink = lambda x: np.column_stack([1e-4 * np.maximum(x[:, 0] - 0.8, 0), 0 * x[:, :2]])
    outcome = find_zone(lambda zone: StretchedBlock(zone, kink), steps, grid, start,
                        np.ones(grid.shape, bool), FT, TripLevels(stress=1.0, stress_every=1),
                        log=lambda line: None)
    lam_2mu = E * (1 - NU) / ((1 + NU) * (1 - 2 * NU))
    expected = start.copy()
    expected[3:] = True
    assert outcome.status == "clean" and np.array_equal(outcome.zone, expected)
    first, second = outcome.attempts
    n = int(np.ceil(FT / (lam_2mu * 1e-4)))          # first step with σ1 ≥ ft
    assert first["tripped_step"] == n and first["cells"] == 1
    assert first["peak_fe_stress_Pa"] == pytest.approx(n * lam_2mu * 1e-4, rel=1e-12)
    assert second["tripped_step"] is None and second["cells"] == 1 + 12
    assert second["peak_fe_stress_Pa"] < 1e-6 * FT
    assert outcome.summary == {"attempt": 1}


def test_limit_stops_the_search():
    grid = CellGrid(P0, P1, N)
    start = np.zeros(grid.shape, bool)
    start[0, 0] = True
    limit = np.zeros(grid.shape, bool)
    limit[:3] = True
    outcome = find_zone(lambda zone: StretchedBlock(zone, uniaxial(1e-5)), steps, grid,
                        start, limit, FT, TripLevels(), log=lambda line: None)
    assert outcome.status == "limit" and len(outcome.attempts) == 1
    assert outcome.attempts[0]["beyond_limit"].endswith("cells that tripped lie outside it")
    assert outcome.summary is None and np.array_equal(outcome.zone, start)
    record = outcome.record(grid, 1000, 30)
    assert record["zone_final"]["n_cells"] == 1 and record["zone_outcome"] == "limit"
    # flagged cells inside the limit, the margin stopped by it: u_x = ε max(x − 0.8, 0) flags
    # i = 4, 5; the margin (i = 3) is outside the limit {i = 0} ∪ {i ≥ 4}
    limit = np.zeros(grid.shape, bool)
    limit[0] = limit[4:] = True
    kink = lambda x: np.column_stack([1e-4 * np.maximum(x[:, 0] - 0.8, 0), 0 * x[:, :2]])
    outcome = find_zone(lambda zone: StretchedBlock(zone, kink), steps, grid, start, limit, FT,
                        TripLevels(), log=lambda line: None)
    expected = start.copy()
    expected[4:] = True
    assert outcome.status == "clean" and np.array_equal(outcome.zone, expected)


def test_a_trip_says_how_far_past_the_limit_it_lies():
    cells = np.zeros((6, 4), bool)
    cells[2:5, 1] = True
    limit = np.zeros((6, 4), bool)
    limit[:3] = True
    assert Tripped(7, "x", cells).beyond(limit) == "2 of the 3 cells that tripped lie outside it"
    limit[:] = True
    assert Tripped(7, "x", cells).beyond(limit) == "no cell to convert inside it"


def test_budget_stops_the_search_before_the_next_attempt():
    """The kink case above grows once and runs clean; a budget that refuses a second attempt
    ends it after the first trip, the zone as it was, the cost named as the limit reached."""
    grid = CellGrid(P0, P1, N)
    start = np.zeros(grid.shape, bool)
    start[0, 0] = True
    kink = lambda x: np.column_stack([1e-4 * np.maximum(x[:, 0] - 0.8, 0), 0 * x[:, :2]])
    seen, lines = [], []
    outcome = find_zone(lambda zone: StretchedBlock(zone, kink), steps, grid, start,
                        np.ones(grid.shape, bool), FT, TripLevels(stress=1.0, stress_every=1),
                        log=lines.append,
                        budget=lambda attempts: seen.append(len(attempts)) or "too dear")
    assert seen == [1] and outcome.status == "limit" and outcome.limit == "cost"
    assert np.array_equal(outcome.zone, start) and outcome.summary is None
    assert lines[-1] == "zone search ends: too dear"
    assert outcome.record(grid, 1000, 30)["zone_limit_reached"] == "cost"


def test_slab_budget_counts_sphere_steps_spent_and_one_whole_run_of_the_last_zone():
    """Full model 10,000 spheres × 1,000 steps = 1e7 sphere steps. Attempts of 4,000 spheres
    × 500 steps and 5,000 × 200: 3e6 spent, and the next attempt ≥ 5,000 × 1,000 = 5e6: 8e6,
    under zone.cost 1 (1e7) and over zone.cost 0.8 (8e6 is not below it); 0 never stops."""
    from cases.slab import SlabSpec
    from cases.slab.search import over_budget, search_cost
    attempts = [{"spheres": 4000, "steps_run": 500}, {"spheres": 5000, "steps_run": 200}]
    spec = SlabSpec(steps=1000, zone_cost=1.0)
    assert search_cost(attempts, 1000) == (3_000_000, 5_000_000)
    assert over_budget(attempts, 10_000, spec) is None
    assert over_budget(attempts, 10_000, SlabSpec(steps=1000, zone_cost=0.0)) is None
    why = over_budget(attempts, 10_000, SlabSpec(steps=1000, zone_cost=0.8))
    assert why == ("3e+06 sphere steps spent and at least 5e+06 for the next attempt reach "
                   "zone.cost = 0.8 × the full model's 1e+07")


def test_a_growing_zone_counts_its_conversions_in_its_budget():
    """Full model 1e7 sphere steps. Zones of 2,000 spheres for 100 steps, then 3,000 for 50
    (one conversion: 60 steps of the first grown zone, 3,000 spheres, and 6 of its own:
    1.98e5), asking at step 150 for another: 5.48e5 spent, at least 1.98e5 + 3,000 × 850 =
    2.748e6 to come: 3.296e6, over zone.cost 0.32 (3.2e6), which the sphere steps alone
    (2.9e6) would not reach. A later conversion's fixed part stays that of the first zone."""
    from cases.slab import SlabSpec
    from cases.slab.grow import conversion_cost, over_budget
    assert conversion_cost(3000, 3000) == 198_000
    assert conversion_cost(3000, 9000) == 60 * 3000 + 6 * 9000
    segments = [(2000, 100), (3000, 50)]
    assert over_budget(segments, 150, 10_000, SlabSpec(steps=1000)) is None
    assert over_budget(segments, 150, 10_000, SlabSpec(steps=1000, zone_cost=0.0)) is None
    assert over_budget(segments, 150, 10_000, SlabSpec(steps=1000, zone_cost=0.33)) is None
    why = over_budget(segments, 150, 10_000, SlabSpec(steps=1000, zone_cost=0.32))
    assert why == ("5.48e+05 sphere steps run (each conversion counted as 60 steps of the "
                   "first grown zone and 6 of its own) and at least 2.748e+06 to come reach "
                   "zone.cost = 0.32 × the full model's 1e+07")
    # a second conversion, to 9,000 spheres, at step 170: its fixed part is the first zone's
    segments = [(2000, 100), (3000, 50), (9000, 20)]
    spent = 2000 * 100 + 3000 * 50 + 9000 * 20 + 198_000 + (180_000 + 54_000)
    rest = 180_000 + 54_000 + 9000 * 830
    above, at = ((spent + rest + 1) / 1e7, (spent + rest) / 1e7)
    assert over_budget(segments, 170, 10_000, SlabSpec(steps=1000, zone_cost=above)) is None
    assert over_budget(segments, 170, 10_000, SlabSpec(steps=1000, zone_cost=at))


@pytest.mark.parametrize("kwargs, message", [
    (dict(stress=0.0), r"trip_stress must be in \(0, 100\]"),
    (dict(omega=1.5), r"trip_omega must be in \(0, 1\]"),
    (dict(band=0.0), r"trip_band must be in \(0, 1\]"),
    (dict(stress_every=0), "stress_every must be an integer >= 1"),
])
def test_bad_trip_levels(kwargs, message):
    with pytest.raises(ValueError, match=message):
        TripLevels(**kwargs)


@pytest.mark.parametrize("options, message", [
    (dict(trip_stress=-1.0), r"^slab: trip_stress must be in \(0, 100\] .*, got -1.0$"),
    (dict(trip_omega=2.0), r"^slab: trip_omega must be in \(0, 1\] .*, got 2.0$"),
    (dict(zone_start=3.0), r"^slab: zone.start = 3.0 m: a DE zone of 19 cells .* do not fit in the 15 cells"),
    (dict(zone_cost=-1.0), r"^slab: zone_cost must be .*, got -1.0$"),
    (dict(zone_start=0.6, zone_limit=0.3),
     r"^slab: zone limit \(36 cells\) does not hold the start zone \(20 cells\)"),
])
def test_slab_refuses_bad_auto_zone_options(options, message):
    from cases.slab import SlabSpec
    with pytest.raises(ValueError, match=message) as e:
        SlabSpec(zone="auto", **options)
    assert "\n" not in str(e.value)


def test_slab_limit_default_leaves_band_and_a_cell_before_the_supports():
    from cases.slab import SlabSpec
    from cases.slab.zone import check
    # the default: one band layer, the start a 0.5 m box (3 x 4 cells of 1/6 m)
    base, start, limit, _ = check(SlabSpec(zone="auto"))
    assert limit.shape == (15, 12)
    assert np.flatnonzero(limit.any(axis=1)).tolist() == list(range(2, 13)) and limit[2:13].all()
    assert np.argwhere(start).tolist() == [[i, j] for i in range(6, 9) for j in range(4, 8)]
    # three layers: the strip leaves columns 0-3 and 11-14; a 0.6 m full-width start
    base, start, limit, _ = check(SlabSpec(zone="auto", de_zone=0.6, full_width=True, layers=3))
    assert np.flatnonzero(limit.any(axis=1)).tolist() == list(range(4, 11)) and limit[4:11].all()
    assert np.array_equal(np.argwhere(start.any(axis=1)).ravel(), np.arange(5, 10)) and start[5:10].all()


def test_case_files_take_zone_auto_and_its_table():
    """`[slab] zone = "auto"` and the `[zone]` table reach SlabSpec; a bad level is refused
    with its one line among the case file's problems."""
    from pathlib import Path
    from cases.kinds import load_case
    from cases.slab.casefile import spec as slab_spec
    slab_toml = Path(__file__).resolve().parents[1] / "cases" / "slab.toml"
    spec = slab_spec(load_case(slab_toml, ["slab.zone=auto", "zone.start=0.3",
                                           "zone.trip_omega=0.2", "zone.fallback=full"]))
    assert (spec.zone, spec.zone_start, spec.trip_omega, spec.fallback) == ("auto", 0.3, 0.2, "full")
    with pytest.raises(ValueError, match=r"\n  - zone.trip_stress = 200.0: must be in \(0, 100\]"):
        load_case(slab_toml, ["slab.zone=auto", "zone.trip_stress=200.0"])


def test_the_post_run_check_reads_the_runs_peak_stress_not_its_last():
    """A stretch that rises to step 10 and falls back: σ1 = von Mises = E ε (uniaxial, exact on
    Q1 cells) peaks at E · 10 δ = 4.2 MPa > ft at step 10 and ends at E · 2 δ = 0.84 MPa;
    the recorder keeps the peak and its time, and the paper's check warns of it."""
    from types import SimpleNamespace
    from orchestrator.run.checks import post_run_checks
    from orchestrator.run.outputs import fe_peak
    from orchestrator.run.record import Recorder
    from orchestrator.run.restart import Record
    delta, dt = 1.4e-5, 1e-6
    m = StretchedBlock(np.zeros((6, 4), bool), uniaxial(1.0))
    recorder = SimpleNamespace(m=m, rec=Record(), fe_read=None)    # no band: every cell
    for n in range(1, 19):
        m.fe.u = min(n, 20 - n) * m.field * delta
        Recorder._fe_peak(recorder, n * dt)
    peak = fe_peak(recorder.rec)
    assert peak["max_principal_Pa"] == pytest.approx(E * 10 * delta, rel=1e-12)
    assert peak["von_mises_Pa"] == pytest.approx(E * 10 * delta, rel=1e-12)
    assert peak["max_principal_t_s"] == peak["von_mises_t_s"] == 10 * dt
    assert m.fe.stress().max_principal.max() == pytest.approx(E * 2 * delta, rel=1e-12)
    assert post_run_checks(peak, np.zeros(0), FT, 40e6) == [
        "FE principal stress 4.20 MPa (at t = 0.01 ms) exceeds the tensile strength 3.00 MPa: "
        "the DE zone may be too small"]
    assert post_run_checks(peak, np.zeros(0), 5e6, 40e6) == []


def test_the_post_run_check_reads_the_cells_outside_the_band():
    """u_x = ε min(x, 0.4) (0.8 − y) / 0.8 around the zone cell (0, 0): the stress falls with
    y, so the largest σ1 is in a band cell; the recorder's peak is the largest of the cells
    outside the band (the in-plane cells of BAND less the zone's, counted from the cells'
    centres here), as the zone's trip reads them."""
    from types import SimpleNamespace
    from orchestrator.run.checks import fe_cells_checked
    from orchestrator.run.record import Recorder
    from orchestrator.run.restart import Record
    zone = np.zeros((6, 4), bool)
    zone[0, 0] = True
    m = StretchedBlock(zone, lambda x: np.column_stack(
        [1e-5 * np.minimum(x[:, 0], 0.4) * (0.8 - x[:, 1]) / 0.8, 0 * x[:, :2]]))
    recorder = SimpleNamespace(m=m, rec=Record(), fe_read=fe_cells_checked(m))
    m.step()
    Recorder._fe_peak(recorder, 1e-6)
    centres = m.fe.nodes[m.fe.cell_nodes].mean(axis=1)
    i, j = (centres[:, 0] // 0.2).astype(int), (centres[:, 1] // 0.2).astype(int)
    outside = ~BAND[i, j]
    s1 = m.fe.stress().max_principal
    assert np.count_nonzero(~outside) == 3 and s1[~outside].max() > s1[outside].max()
    assert recorder.rec.fe_peak[0] == s1[outside].max()


def test_the_post_run_damage_check_reads_the_cells_outside_the_band():
    """A band cell past the trip level does not warn; a cell outside the band does."""
    from orchestrator.run.checks import post_run_checks
    assert post_run_checks(None, np.zeros(0), FT, 40e6, {"max": 0.99, "max_checked": 0.5},
                           0.9) == []
    assert post_run_checks(None, np.zeros(0), FT, 40e6, {"max": 0.99, "max_checked": 0.95},
                           0.9) == ["FE damage 0.950 reaches 0.9 (the zone's trip level) in "
                                    "the FE part outside the bridging band: the DE zone may "
                                    "be too small"]


def test_an_ensemble_member_whose_zone_search_ends_at_its_limit_is_named_as_such(tmp_path):
    """An outcome (exit 1 and a zone at its limit: the ensemble exits 1, as one run does),
    not a fault (any other exit, or no summary: the ensemble exits 2)."""
    import json
    from cli.commands.slab import _why_no_result
    (tmp_path / "summary.json").write_text(json.dumps(
        {"zone_outcome": "limit", "zone_limit_reached": "cost", "zone_attempts": [{}] * 9}))
    assert _why_no_result(tmp_path, 1) == ("coupling cannot pay: its zone search reached the "
                                           "budget, zone.cost after 9 attempts", True)
    assert _why_no_result(tmp_path, 2) == ("exit 2", False)
    assert _why_no_result(tmp_path / "none", 1) == ("exit 1", False)
    (tmp_path / "summary.json").write_text(json.dumps(
        {"zone_outcome": "limit", "zone_limit_reached": "cells", "zone_conversions": [{}] * 2}))
    assert _why_no_result(tmp_path, 1) == ("coupling cannot pay: its growing zone reached the "
                                           "zone's limit after 2 conversions", True)


def test_ahead_flags_the_cells_past_its_share_of_the_level_and_only_those_that_tripped_limit():
    """With ahead < 1 a trip flags the cells whose indicator passed ahead × the level too;
    the zone's limit is judged on the cells that tripped alone, the others stop at it."""
    from orchestrator.run.autozone import _trip
    grid = CellGrid(P0, P1, N)                        # 6 × 4 cells of 0.2 m
    centres = (np.argwhere(np.ones(grid.shape, bool)) + 0.5) * grid.size[:2]
    points = np.column_stack([centres, np.full(len(centres), 0.1)])
    x = points[:, 0]
    values = np.select([x > 1.0, x < 0.2, (x > 0.4) & (x < 0.6)], [1.0, 0.6, 0.3], 0.0)
    with pytest.raises(Tripped) as t:
        _trip(7, values, 1.0, "{} cells", points, grid, ahead=0.5)
    tripped = t.value
    column = lambda mask: sorted(set(np.argwhere(mask)[:, 0].tolist()))
    assert column(tripped.cells) == [5] and column(tripped.near) == [0, 5]
    zone = np.zeros(grid.shape, bool)
    zone[3] = True
    limit = np.zeros(grid.shape, bool)
    limit[1:] = True                                  # not column 0, which is only near
    assert column(tripped.grown(zone, grid, 1, limit)) == [3, 4, 5]
    assert column(tripped.grown(zone, grid, 1, np.ones(grid.shape, bool))) == [0, 1, 3, 4, 5]
    limit[5] = False                                  # the cells that tripped are outside
    assert tripped.grown(zone, grid, 1, limit) is None


class BreakingBand(StretchedBlock):
    """The unstretched block with three bridging spheres in band cells (1, 0), (0, 1), (1, 1)
    and one sphere in the zone, each with ten initial links; at step n the sphere in (1, 0)
    has lost n of its links (its damage n / 10, its worst link broken from step 1), the zone's
    sphere all of them."""

    class Links:
        def __init__(self, block):
            self.block = block

        def update(self):
            return np.array([min(self.block.n, 10) / 10, 0.0, 0.0, 1.0])

        def worst_link(self):
            return np.array([1.0 if self.block.n else 0.0, 0.0, 0.0, 1.0])

    def __init__(self, zone):
        super().__init__(zone, lambda x: 0 * x)
        self.bridge_index = np.array([0, 1, 2])
        self.spheres = type("Spheres", (), {"ref_pos": np.array(
            [[0.3, 0.1, 0.1], [0.1, 0.3, 0.1], [0.3, 0.3, 0.1], [0.1, 0.1, 0.1]])})()
        self.damage = self.Links(self)


def test_the_band_trips_on_a_bridging_sphere_with_no_link_left_or_on_its_first_broken_link():
    """trip_band 1: the sphere of cell (1, 0) loses its last link at step 10, the trip there
    flags its cell alone (the zone's own sphere, all links gone, is not read); 0.5 at step 5.
    Without trip_band the link check trips at its first broken link, step 1."""
    grid = CellGrid(P0, P1, N)
    zone = np.zeros(grid.shape, bool)
    zone[0, 0] = True
    for band, step in ((1.0, 10), (0.5, 5), (None, 1)):
        m = BreakingBand(zone)
        watch = Watch(m, grid, FT, TripLevels(links_every=1, band=band))
        with pytest.raises(Tripped) as e:
            steps(m, 0)
        assert e.value.step == step
        flagged = np.zeros(grid.shape, bool)
        flagged[1, 0] = True
        assert np.array_equal(e.value.cells, flagged)
        if band is None:
            assert "bridging link ω 1 ≥ 1 at 1 spheres" in e.value.indicator
        else:
            assert f"bridging sphere damage {band:g} ≥ {band:g} at 1 spheres" in e.value.indicator
            assert watch.peak_band == band
