"""The study "where coupling pays": its plan, its reuse of finished runs, and its table built
from synthetic run folders with known spreads (no model is built)."""
import json
from dataclasses import asdict, replace
from types import SimpleNamespace

import numpy as np
import pytest

from cases.slab.study import plan as sp
from cases.slab.study import report
from cases.slab.study import table as st
from cases.slab.probes import add_probes, probe_name
from cases.slab.study.runs import execute, missing_probes, probes_needed
from common.files import save_npz, write_json
from cli.main import main
from orchestrator.run.folder import MARKER
from orchestrator.run.outputs import write_sensors

NAMES = ["under_impact", "de_zone", "bridging", "fe_node"]
T = np.linspace(0.0, 1e-3, 101)
SHAPE = np.sin(np.pi * T / T[-1])
RMS = np.sqrt(np.mean(SHAPE**2))
BENCH = sp.load_bench()


def runs_at(v, seeds=(1, 2, 3)):
    return sp.plan(only="medium", velocities=[v], seeds=seeds, bench=BENCH)


def by_name(runs, name, seed):
    return next(r for r in runs if r.config.name == name and r.seed == seed)


def write_member(folder, run, amplitude, volume=1.0, s_per_step=1.0, spheres=None,
                 probes=None, extra=None):
    """A finished run of the planned `run`: z histories amplitude × SHAPE on every sensor
    (probes: {label: amplitude} of a full run's probe sensors), its recorded spec the plan's."""
    folder.mkdir(parents=True)
    (folder / MARKER).write_text("")
    names = list(NAMES)
    amps = [amplitude] * len(NAMES)
    for label, a in (probes or {}).items():
        names += [probe_name(label, n) for n in NAMES[1:]]
        amps += [a] * 3
    full = run.config.model == "full"
    summary = {"model": run.config.model, "spec": asdict(run.spec()), "steps": 100,
               "dt": 1e-5, "wall_s": 100.0 * s_per_step, "s_per_step": s_per_step,
               "n_spheres": spheres or (10 if full else 6), "n_fe_nodes": 0 if full else 50,
               "n_bridging_spheres": 0 if full else 3,
               "sensors": {n: {"position": [0, 0, 0]} for n in names},
               "damage": {"damaged_volume_m3": volume, "broken_links": 10 * volume}}
    summary.update(extra or {})
    write_json(folder / "summary.json", summary)
    h = np.zeros((len(T), len(names), 3))
    h[:, :, 2] = SHAPE[:, None] * np.array(amps)[None, :]
    write_sensors(folder / "sensors.csv", names, T, h)
    n = summary["n_spheres"]
    save_npz(folder / "damage.npz", times=np.array([0.0, T[-1]]),
             damage=np.zeros((2, n)), positions=np.zeros((n, 3)), radius=np.full(n, 0.02),
             in_de_zone=np.arange(n) < 4, slab_index=np.arange(n))
    return folder


def write_limit(folder, run, wall=500.0):
    """An automatic-zone run that reached its limit (no results but the search)."""
    folder.mkdir(parents=True)
    write_json(folder / "summary.json", {
        "model": "coupled", "spec": asdict(run.spec()), "zone_outcome": "limit",
        "zone_attempts": [{"wall_s": wall / 2}, {"wall_s": wall / 2}],
        "zone_total_wall_s": wall, "zone_message": "coupling cannot pay for this impact: ...",
        "full_model_projected": {"wall_s": 400.0}})


def full_ensemble(out, runs, probes=None, amplitudes=(0.9, 1.0, 1.1), volumes=(0.9, 1.0, 1.1)):
    for seed, a, vol in zip((1, 2, 3), amplitudes, volumes):
        r = by_name(runs, "full", seed)
        write_member(out / r.folder, r, a, volume=vol, s_per_step=3.0, probes=probes)


@pytest.fixture()
def forty(tmp_path):
    """At 40 m/s: full 0.9, 1.0, 1.1 × SHAPE (damaged volumes likewise); the default zone's
    seed 1 at 1.02 (volume 1.05, 6x faster per step); the automatic zone at its limit."""
    runs = runs_at(40.0)
    full_ensemble(tmp_path, runs)
    d = by_name(runs, "zone-0.9m-strip-nb3", 1)
    write_member(tmp_path / d.folder, d, 1.02, volume=1.05, s_per_step=0.5)
    a = by_name(runs, "auto-nb3", 1)
    write_limit(tmp_path / a.folder, a)
    return runs, tmp_path


def test_table_gives_the_known_deviations_and_verdicts(forty):
    runs, out = forty
    table = st.build(runs, out)
    (impact,) = table["impacts"]
    assert impact["full"]["seeds"] == [1, 2, 3]
    rows = {r["config"]: r for r in impact["configs"]}
    row = rows["zone-0.9m-strip-nb3"]
    s = row["accuracy"]["sensors"]["bridging"]
    # coupled 1.02 against the mean 1.0; the full members' leave-one-out deviations:
    # 0.9 against 1.05, 1.0 against 1.0, 1.1 against 0.95 (sensors.csv: 10 digits)
    assert s["nrms"]["coupled_max"] == pytest.approx(0.02 * RMS, abs=2e-9)
    assert s["nrms"]["full_leave_one_out_max"] == pytest.approx(0.15 / 0.95 * RMS, abs=2e-9)
    assert s["peak"]["coupled_max"] == pytest.approx(0.02, abs=2e-9)
    assert s["peak"]["full_leave_one_out_max"] == pytest.approx(0.15 / 0.95, abs=2e-9)
    assert s["within"] is True
    v = row["accuracy"]["damage"]["damaged_volume_m3"]
    assert v["ratio_to_full_mean"] == [pytest.approx(1.05)]
    assert v["verdict"]["full_leave_one_out_max"] == pytest.approx(0.15 / 0.95)
    assert v["verdict"]["within"] is True
    assert row["sphere_ratio"] == pytest.approx(10 / 6)
    assert row["speedup"]["value"] == pytest.approx(6.0)
    assert "separate runs" in row["speedup"]["source"]
    assert row["cost"]["total_wall_s"] == pytest.approx(50.0)
    assert row["goal"]["qualifies"] is True and row["goal"]["within_scatter"] is True
    auto = rows["auto-nb3"]
    assert auto["zone_limit_seeds"] == [1] and auto["goal"]["qualifies"] is False
    assert auto["cost"]["total_wall_s"] == 500.0 and auto["cost"]["attempts"] == {1: 2}
    assert "limit" in auto["goal"]["why"]
    assert auto["missing"] == [2, 3]          # seeds 2 and 3 did not run: seed 1 hit the limit


def test_one_sensor_outside_or_too_slow_fails_the_goal(forty):
    runs, out = forty
    d = by_name(runs, "zone-0.9m-strip-nb3", 1)
    folder = out / d.folder
    h = np.zeros((len(T), 4, 3))
    h[:, :, 2] = SHAPE[:, None] * np.array([1.0, 1.0, 1.3, 1.0])[None, :]
    write_sensors(folder / "sensors.csv", NAMES, T, h)
    row = st.build(runs, out)["impacts"][0]["configs"][0]
    assert row["accuracy"]["sensors"]["bridging"]["within"] is False
    assert row["accuracy"]["sensors"]["de_zone"]["within"] is True
    assert row["goal"]["qualifies"] is False
    assert row["goal"]["why"].startswith("outside the full scatter: bridging")
    # the one-window timing, when it holds both models, decides the speed-up
    full1 = by_name(runs, "full", 1)
    timing = {full1.folder: {"step_s": 2.0}, d.folder: {"step_s": 1.0}}
    row = st.build(runs, out, timing=timing)["impacts"][0]["configs"][0]
    assert row["speedup"]["value"] == 2.0 and row["speedup"]["runs"] == pytest.approx(6.0)
    assert "timed back to back" in row["speedup"]["source"]
    assert "2.00x < 5x per step" in row["goal"]["why"]


def test_a_zone_of_its_own_is_compared_at_its_probes(tmp_path):
    """At the sweep velocity a larger zone's sensors sit elsewhere: the full members carry
    them as probes (here at amplitudes 2 × theirs) and the coupled run is judged there."""
    runs = runs_at(sp.SWEEP_VELOCITY)
    label = "zone-1.3m-strip-nb1"
    r = by_name(runs, label, 1)
    assert st.layout_label(r) == label
    for seed, a in zip((1, 2, 3), (0.9, 1.0, 1.1)):
        f = by_name(runs, "full", seed)
        write_member(tmp_path / f.folder, f, a, s_per_step=3.0, probes={label: 2 * a})
    write_member(tmp_path / r.folder, r, 2.0)
    rows = {x["config"]: x for x in st.build(runs, tmp_path)["impacts"][0]["configs"]}
    s = rows[label]["accuracy"]["sensors"]
    assert s["fe_node"]["nrms"]["coupled_max"] == pytest.approx(0.0, abs=2e-9)
    # under_impact sits where the full model's does: against its own 1.0 mean
    assert s["under_impact"]["nrms"]["coupled_max"] == pytest.approx(RMS, abs=2e-9)
    assert rows[label]["goal"]["within_scatter"] is False      # under_impact: 2 against 1
    assert rows["zone-0.9m-strip-nb1"]["missing"] == [1]


def test_full_runs_without_the_probes_are_not_judged_and_are_rerun(tmp_path):
    runs = runs_at(sp.SWEEP_VELOCITY)
    full_ensemble(tmp_path, runs)
    r = by_name(runs, "zone-0.5m-box-nb2", 1)
    write_member(tmp_path / r.folder, r, 1.0)
    row = next(x for x in st.build(runs, tmp_path)["impacts"][0]["configs"]
               if x["config"] == r.config.name)
    assert row["accuracy"]["judged"] is False and "rerun them" in row["accuracy"]["why"]
    # too slow anyway (3x): the goal fails whatever the scatter would say
    assert row["goal"]["qualifies"] is False and row["goal"]["within_scatter"] is None
    assert row["goal"]["why"].startswith("3.00x < 5x per step; the full run(s)")
    needed = probes_needed([x for x in runs], {})
    assert "zone-0.5m-box-nb2" in needed and "zone-0.9m-strip-nb3" not in needed
    f = by_name(runs, "full", 1)
    summary = json.loads((tmp_path / f.folder / "summary.json").read_text())
    assert "zone-0.5m-box-nb2" in missing_probes(summary, needed)
    outcomes = execute(runs, tmp_path, {}, log=lambda line: None, dry=True)
    assert outcomes[f.folder].status == "to run"              # lacks the probes: rerun
    assert outcomes[r.folder].status == "done"


def test_a_zone_that_qualifies_on_one_seed_is_confirmed_on_the_others(forty):
    runs, out = forty
    (config,) = st.qualifying_configs(st.build(runs, out), runs)
    assert config.name == "zone-0.9m-strip-nb3"
    extra = sp.confirmations(runs, [config])
    assert [(r.config, r.seed, r.steps) for r in extra] == [(config, 2, None), (config, 3, None)]
    assert sp.confirmations(runs + extra, [config]) == []        # planned once
    for r, a in zip(extra, (1.01, 1.3)):         # seed 3 lies outside the full members' 0.9-1.1
        write_member(out / r.folder, r, a, volume=1.0, s_per_step=0.5)
    row = st.build(runs + extra, out)["impacts"][0]["configs"][0]
    assert row["seeds"] == [1, 2, 3] and row["goal"]["qualifies"] is False
    assert row["accuracy"]["sensors"]["fe_node"]["nrms"]["coupled_max"] == pytest.approx(
        0.3 * RMS, abs=2e-9)
    assert row["goal"]["why"].startswith("outside the full scatter: under_impact, de_zone")


def test_a_scatter_a_null_prediction_lies_in_is_named_and_checks_are_shown(tmp_path):
    """Full damaged volumes 0.2, 1.0, 3.0: leave-one-out deviations up to 3 / 0.6 - 1 = 4, past
    the null prediction's 1; the histories' (0.9-1.1: 0.158 RMS) are below its RMS / 1."""
    runs = runs_at(40.0)
    full_ensemble(tmp_path, runs, volumes=(0.2, 1.0, 3.0))
    d = by_name(runs, "zone-0.9m-strip-nb3", 1)
    warning = ("FE principal stress 5.66 MPa exceeds the tensile strength 3.76 MPa: the DE "
               "zone may be too small")
    write_member(tmp_path / d.folder, d, 1.0, volume=0.5, s_per_step=0.5,
                 extra={"warnings": [warning]})
    table = st.build(runs, tmp_path)
    row = table["impacts"][0]["configs"][0]
    v = row["accuracy"]["damage"]["damaged_volume_m3"]["verdict"]
    assert v["full_leave_one_out_max"] == pytest.approx(4.0) and v["null_within"] is True
    assert row["accuracy"]["sensors"]["bridging"]["null_within"] is False
    assert row["goal"]["qualifies"] is True and row["goal"]["null_within"] == ["damaged volume"]
    assert "a null prediction, no displacement or no damage, is within it too on: damaged " \
           "volume" in row["goal"]["why"]
    table["table1"] = None
    shown = "FE principal stress 5.66 MPa exceeds the tensile strength 3.76 MPa"
    assert f"| {shown} |" in report.markdown(table)
    outcomes = execute(runs, tmp_path, {}, log=lambda line: None, dry=True)
    text = report.doc(table, runs, outcomes, 3600.0, "default", {}, "study")
    assert f"the paper's post-run checks: {shown}" in text
    # a summary without fe_peak_stress was written before the peak was recorded
    assert "1 of the 1 coupled runs here were written before the peak was recorded" in text


def test_one_full_paper_run_gives_the_paired_goals_and_table1(tmp_path):
    runs = sp.plan(only="paper", bench=BENCH)
    assert [r.config.name for r in runs] == ["zone-0.5m-box-nb1", "full"]
    c, f = runs
    assert c.chosen and c.steps == f.steps >= 5e-3 / BENCH["paper"]["full"]["dt"]
    write_member(tmp_path / f.folder, f, 1.0, s_per_step=4.0, spheres=120000)
    write_member(tmp_path / c.folder, c, 1.0, s_per_step=1.0, spheres=28000)
    table = st.build(runs, tmp_path)
    row = table["impacts"][0]["configs"][0]
    assert row["accuracy"]["judged"] is False
    assert row["accuracy"]["absolute_goals"][0]["peaks_within_10_percent"] is True
    assert row["goal"]["qualifies"] is False and "4.00x < 10x" in row["goal"]["why"]
    t1 = report.table1(table)
    assert t1["coupled"]["spheres"] == 28000 and t1["coupled"]["n_b"] == 1
    assert t1["coupled"]["projected_100k_steps_s"]["run"] == pytest.approx(1e5 * 1.0)
    assert t1["full"]["projected_100k_steps_s"]["run"] == pytest.approx(4e5)


def test_the_default_plan_fits_its_budget_and_the_full_sweep_is_larger():
    default, full = (sp.plan(s, bench=BENCH) for s in sp.SWEEPS)
    cost = lambda runs: (sum(sp.run_cost(r, BENCH) for r in runs if r.when is None)
                         + sp.timing_cost(runs, BENCH))
    assert cost(default) <= sp.BUDGET_S < cost(full)
    groups = {r.config.group for r in default}
    assert groups == {"medium-10ms", "medium-40ms", "paper-40ms"}
    assert {r.config.group for r in full} >= {"medium-20ms"}
    # the full sweep's reinforced slab: an impact of its own at each velocity, its full
    # members reinforced too; the default plan has none, and a graded row at each velocity
    for v in ("10", "20", "40"):
        rf = [r for r in full if r.config.group == f"medium-{v}ms-reinforced"]
        assert {r.config.name for r in rf} == {"full", "zone-0.9m-strip-nb3", "auto-nb3"}
        assert all(r.spec().reinforced for r in rf) and len(rf) == 9
    assert not any(r.spec().reinforced for r in default)
    assert sum(r.config.name == "zone-0.9m-strip-nb3-graded-2d" for r in default) == 2
    # every impact has its full ensemble of three seeds, after its coupled runs
    for g in ("medium-10ms", "medium-40ms"):
        members = [r for r in default if r.config.group == g]
        assert [r.seed for r in members if r.config.model == "full"] == [1, 2, 3]
        assert all(r.config.model == "full" for r in members[-3:])
    sweep = {r.config.name for r in default if r.config.group == "medium-10ms"}
    assert {f"zone-{z}-nb{n}" for z in ("0.9m-strip", "1.3m-strip", "0.5m-box")
            for n in (1, 2, 3)} <= sweep
    assert len({r.folder for r in full}) == len(full)
    # the FE that cracks beside the elastic one: the small box at each impact, the default
    # zone at 40 m/s; their sensors sit where their elastic twins' do
    names = lambda g: {r.config.name for r in default if r.config.group == g}
    assert {"zone-0.5m-box-nb1-damage", "zone-0.5m-box-nb1"} <= names("medium-10ms")
    assert {"zone-0.9m-strip-nb3-damage", "zone-0.5m-box-nb1-damage",
            "zone-0.5m-box-nb1"} <= names("medium-40ms")
    damage = [r for r in default if r.config.fe_material == "damage"]
    assert len(damage) == 3 and all(r.spec().fe_material == "damage" for r in damage)
    assert all(r.config.layout == replace(r.config, fe_material="elastic").name
               for r in damage)


def test_the_cost_model_reproduces_the_benchmark_models():
    from cases.slab import SlabSpec
    for scale in ("small", "medium", "paper"):
        spec = SlabSpec(scale=scale)            # the benchmark's coupled model: the default
        b = BENCH[scale]["coupled"]
        spheres, bridging, nodes = sp.counts(spec, BENCH[scale]["full"]["n_spheres"])
        assert spheres == pytest.approx(b["n_spheres"], rel=0.03)
        assert bridging == pytest.approx(b["n_bridging_spheres"], rel=0.05)
        assert nodes == b["n_fe_nodes"]


def test_finished_runs_are_reused_here_or_from_an_ensemble(tmp_path, capsys):
    runs = runs_at(40.0)
    f1 = by_name(runs, "full", 1)
    write_member(tmp_path / "study" / f1.folder, f1, 1.0)
    # make validate's layout: results/slab-medium/full/seed-N
    f2 = by_name(runs, "full", 2)
    write_member(tmp_path / "validate" / "full" / "seed-2", f2, 1.0)
    other = replace(f2.config, velocity=20.0)
    write_member(tmp_path / "validate" / "full-20" / "seed-3", sp.Planned(other, 3), 1.0)
    index = sp.ensemble_index([tmp_path / "validate"])
    assert sp.where(f1, tmp_path / "study", index)[1] is not None
    folder, s = sp.where(f2, tmp_path / "study", index)
    assert folder == tmp_path / "validate" / "full" / "seed-2" and s is not None
    assert sp.where(by_name(runs, "full", 3), tmp_path / "study", index)[1] is None  # 20 m/s
    assert main(["study", "--dry-run", "--only", "medium", "--velocities", "40", "--out",
                 str(tmp_path / "study"), "--reuse-ensembles", str(tmp_path / "validate")]) == 0
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines()}
    assert lines[f1.folder].endswith("done")
    assert "reused: " in lines[f2.folder] and lines["medium-40ms/full/seed-3"].endswith("to run")
    assert "only if medium-40ms/auto-nb3/seed-1 ends clean" in lines["medium-40ms/auto-nb3/seed-2"]


@pytest.mark.parametrize("args, message", [
    (["--velocities", "30"], "velocity 30.0 m/s is not one of the study's (10, 20, 40 m/s)"),
    (["--reuse-ensembles", "/nonexistent-study-folder"], "no such folder"),
])
def test_refusals_are_one_line(tmp_path, capsys, args, message):
    assert main(["study", "--dry-run", "--out", str(tmp_path / "s")] + args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_an_unknown_sweep_is_refused(capsys):
    assert main(["study", "--sweep", "huge", "--dry-run"]) == 2
    assert "invalid choice: 'huge'" in capsys.readouterr().err


def test_an_ensemble_of_mixed_scales_is_refused(tmp_path, capsys):
    runs = runs_at(40.0)
    write_member(tmp_path / "e" / "seed-1", by_name(runs, "full", 1), 1.0)
    small = sp.Planned(replace(by_name(runs, "full", 2).config, scale="small"), 2)
    write_member(tmp_path / "e" / "seed-2", small, 1.0)
    assert main(["study", "--dry-run", "--out", str(tmp_path / "s"),
                 "--reuse-ensembles", str(tmp_path / "e")]) == 2
    err = capsys.readouterr().err
    assert "mixed kinds: members differ in scale: 'medium'" in err
    assert len(err.strip().splitlines()) == 1


def test_probes_are_the_sensors_a_run_of_that_zone_would_have():
    """A stand-in full model: spheres on a line along x through the sensor points; the
    probes of another layout are the spheres nearest that layout's points."""
    from cases.slab.zone import sensor_points, slab_grid
    from cases.slab.model import SlabModel
    spec = sp.Config("medium", 40.0, "full").defaults()
    grid = slab_grid(spec)
    x = np.arange(0.0, 2.5, 0.01)
    pos = np.column_stack([x, np.full_like(x, 1.0), np.full_like(x, 0.14)])
    pos[0] = (1.25, 1.0, spec.radius)               # the sphere under the impact
    got = {}
    m = SimpleNamespace(fe=None, spec=spec, grid=grid, slab=SimpleNamespace(ref_pos=pos),
                        set_sensors=lambda names, idx, nodes, p: got.update(
                            names=names, idx=idx, nodes=nodes, positions=p))
    m._fe_node_position = lambda p: SlabModel._fe_node_position(m, p)
    other = replace(sp.Config("medium", 40.0, "coupled", de_zone=1.3, full_width=True,
                              layers=1).defaults())
    names = add_probes(m, {"wide": (other, slab_grid(other))})
    assert names == NAMES + ["wide/de_zone", "wide/bridging", "wide/fe_node"]
    points = sensor_points(other, slab_grid(other))
    assert pos[got["idx"][4]][0] == pytest.approx(points["de_zone"][0], abs=0.005)
    assert pos[got["idx"][5]][0] == pytest.approx(points["bridging"][0], abs=0.005)
    assert points["bridging"][0] == pytest.approx(1.9 + 0.05)    # 1.3 m strip, one 0.1 m layer
    assert got["idx"][:4] == [0, *got["idx"][1:4]] and got["nodes"] == []
    assert got["positions"].shape == (7, 3)


def test_plots_and_page_follow_the_table(forty):
    runs, out = forty
    table = st.build(runs, out)
    table["table1"] = None
    report.plot_impact(table["impacts"][0], out / "p.png")
    assert (out / "p.png").stat().st_size > 0
    outcomes = execute(runs, out, {}, log=lambda line: None, dry=True)
    text = report.doc(table, runs, outcomes, 3600.0, "default", {}, "study")
    assert "**medium scale, 40 m/s, zone-0.9m-strip-nb3**" in text
    assert "Reinforced concrete: in `--sweep full` only" in text
    # without the qualifying run: "none at this resolution", with the figures
    table["impacts"][0]["configs"][0]["goal"]["qualifies"] = False
    text = report.doc(table, runs, outcomes, 3600.0, "default", {}, "study")
    assert "**None at this resolution.**" in text and "6.00x per step" in text
    md = report.markdown(table)
    assert "| zone-0.9m-strip-nb3 | 1 | 6 | 1.67 | 6.00 (runs) |" in md


@pytest.mark.slow
def test_a_full_run_with_probes_records_what_a_full_run_of_that_zone_records(tmp_path):
    """The full model's physics does not depend on the coupled zone: the probes of a wider
    strip with one layer equal, bit for bit, the sensors of a full run described with it."""
    from cases.slab.zone import slab_grid
    from cases.slab.runs import run
    from cases.slab.probes import run_full
    from orchestrator.run.outputs import read_sensors
    from yade_side import import_yade
    import_yade(1)
    base = sp.Config("small", 40.0, "full").spec(1, 80)
    wide = sp.Config("small", 40.0, "coupled", de_zone=1.2, full_width=True, layers=1).spec(1, 80)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    run_full(base, {"wide": (wide, slab_grid(wide))}, tmp_path / "a", quiet=True)
    run(wide, "full", tmp_path / "b", quiet=True)
    t_a, names_a, h_a = read_sensors(tmp_path / "a" / "sensors.csv")
    t_b, names_b, h_b = read_sensors(tmp_path / "b" / "sensors.csv")
    assert names_b == NAMES and np.array_equal(t_a, t_b)
    assert np.array_equal(h_a[:, 0], h_b[:, 0])
    for k, name in enumerate(NAMES[1:], start=1):
        assert np.array_equal(h_a[:, names_a.index(f"wide/{name}")], h_b[:, k]), name
    assert np.abs(h_b).max() > 0


@pytest.mark.slow
def test_an_interrupted_run_of_the_study_carries_on_from_its_checkpoint(tmp_path):
    """A coupled run that left a checkpoint at step 40 of 60 (its results removed, as if it
    had been stopped there) is carried on, not started again, and ends as the whole run did."""
    from cases.slab.study.runs import run_one
    from orchestrator.run.outputs import read_sensors
    r = sp.Planned(sp.Config("small", 40.0, "coupled"), 1, 60)
    folder = tmp_path / r.folder
    assert main(["slab", "--model", "coupled", "--scale", "small", "--steps", "60",
                 "--zone", "box", "--de-zone", "0.6", "--full-width", "--layers", "3",
                 "--checkpoint-every", "20", "--out", str(folder), "--quiet"]) == 0
    _, _, whole = read_sensors(folder / "sensors.csv")
    for name in ("summary.json", "sensors.csv", "damage.npz"):
        (folder / name).unlink()
    run_one(r, folder, {}, quiet=True, log=lambda line: None)
    assert "resumed from the checkpoint of step 40" in (folder / "run.log").read_text()
    _, _, carried_on = read_sensors(folder / "sensors.csv")
    assert np.array_equal(whole, carried_on)


def test_the_page_counts_the_coupled_runs_whose_fe_check_read_the_last_state():
    NS = SimpleNamespace
    runs = [NS(config=NS(model=m), folder=f) for m, f in
            (("coupled", "a"), ("coupled", "b"), ("coupled", "c"), ("full", "d"))]
    done = {"n_spheres": 1}
    outcomes = {"a": NS(summary=done), "b": NS(summary={**done, "fe_peak_stress": {}}),
                "c": NS(summary=None), "d": NS(summary=done)}
    assert report._last_state_runs(runs, outcomes) == (1, 2)
