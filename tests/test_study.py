"""The study "where coupling pays": its plan, its reuse of finished runs, and its table built
from synthetic run folders with known figures (no model is built), judged by the yardstick as
`compare` judges them."""
import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from cases.slab.quantities import NAMES as QOI, Quantities
from cases.slab.study import plan as sp
from cases.slab.study import report
from cases.slab.study import table as st
from cases.slab.study.runs import execute
from common.files import save_npz, write_json
from cli.main import main
from orchestrator.run.folder import MARKER
from orchestrator.run.outputs import QUANTITIES, write_quantities, write_sensors
from test_compare import qoi_shape

NAMES = ["under_impact", "de_zone", "bridging", "fe_node"]
T = np.linspace(0.0, 1e-3, 101)
BENCH = sp.load_bench()
FULL = {1: 0.98, 2: 1.0, 3: 1.02, 4: 1.0}       # the full members' amplitudes: mean 1


def runs_at(v, sweep="default"):
    return sp.plan(sweep, only="medium", velocities=[v])


def by_name(runs, name, seed):
    return next(r for r in runs if r.config.name == name and r.seed == seed)


def write_member(folder, run, amplitude, s_per_step=1.0, extra=None):
    """A finished run of the planned `run`: every QoI amplitude × its shape (peak mid-window),
    the cracking energy 100 × amplitude J, its recorded spec the plan's."""
    folder.mkdir(parents=True)
    (folder / MARKER).write_text("")
    full = run.config.model == "full"
    n = 10 if full else 6
    summary = {"model": run.config.model, "spec": asdict(run.spec()), "steps": 100,
               "dt": 1e-5, "wall_s": 100.0 * s_per_step, "s_per_step": s_per_step,
               "n_spheres": n, "n_fe_nodes": 0 if full else 50,
               "n_bridging_spheres": 0 if full else 3,
               "damage": {"damaged_volume_m3": 1.0, "broken_links": 10},
               "quantities": {**Quantities.definitions(),
                              "cracking_energy": {"slab_J": 100.0 * amplitude}}}
    summary.update(extra or {})
    write_json(folder / "summary.json", summary)
    h = np.zeros((len(T), len(NAMES), 3))
    write_sensors(folder / "sensors.csv", NAMES, T, h)
    write_quantities(folder / QUANTITIES, QOI, T, amplitude * qoi_shape())
    save_npz(folder / "damage.npz", times=np.array([0.0, T[-1]]), damage=np.zeros((2, n)),
             positions=np.zeros((n, 3)), radius=np.full(n, 0.02), in_de_zone=np.arange(n) < 4,
             slab_index=np.arange(n))
    return folder


def write_limit(folder, run, wall=500.0):
    """A grown-zone run stopped at its limit (no results but its growth record)."""
    folder.mkdir(parents=True)
    write_json(folder / "summary.json", {
        "model": "coupled", "spec": asdict(run.spec()), "zone_outcome": "limit",
        "zone_total_wall_s": wall, "zone_message": "coupling cannot pay for this impact: ..."})


def members(out, runs, name, amplitudes, **kw):
    for seed, a in amplitudes.items():
        r = by_name(runs, name, seed)
        write_member(out / r.folder, r, a, **kw)


@pytest.fixture()
def forty(tmp_path):
    """At 40 m/s: the full ensemble FULL (3 s a step); the 0.5 m box 1.01 × its pair (6×
    faster per step), the grown zone 1.2 × its pair (one conversion each)."""
    runs = runs_at(40.0)
    members(tmp_path, runs, "full", FULL, s_per_step=3.0)
    members(tmp_path, runs, "box-0.5m", {s: 1.01 * a for s, a in FULL.items()},
            s_per_step=0.5)
    members(tmp_path, runs, "grown", {s: 1.2 * a for s, a in FULL.items()}, s_per_step=1.0,
            extra={"zone_conversions": [{}]})
    return runs, tmp_path


def row(table, name):
    return next(r for r in table["impacts"][0]["configs"] if r["config"] == name)


def test_the_plan_runs_every_zone_on_the_seeds_the_yardstick_needs():
    default, full = sp.plan("default"), sp.plan("full")
    assert {r.config.group for r in default} == {"medium-10ms", "medium-40ms"}
    for g in ("medium-10ms", "medium-40ms"):
        got = [(r.config.name, r.seed) for r in default if r.config.group == g]
        assert got == [(n, s) for n in ("full", "box-0.5m", "grown") for s in (1, 2, 3, 4)]
    specs = {r.config.name: r.spec() for r in default if r.config.group == "medium-40ms"}
    assert specs["full"].zone == "box" and specs["full"].fe_material == "elastic"
    assert (specs["box-0.5m"].zone, specs["box-0.5m"].de_zone) == ("box", 0.5)
    assert specs["grown"].zone == "grow" and specs["grown"].fe_material == "damage"
    assert {s.steps for s in specs.values()} == {5480}      # the map's window
    # the full sweep: 20 m/s, the 1.0 m box, the reinforced slab with the boxes, the paper
    # scale with the grown zone (no medium choice given) on seeds 1-3
    names = lambda g: {r.config.name for r in full if r.config.group == g}   # noqa: E731
    assert names("medium-20ms") == {"full", "box-0.5m", "box-1m", "grown"}
    assert names("medium-40ms-reinforced") == {"full", "box-0.5m", "box-1m"}
    assert all(r.spec().reinforced for r in full if "reinforced" in r.config.group)
    paper = [r for r in full if r.config.scale == "paper"]
    assert {(r.config.group, r.config.name) for r in paper} == {
        (f"paper-{v}ms", n) for v in (10, 20, 40) for n in ("full", "grown")}
    assert {r.seed for r in paper} == {1, 2, 3}
    assert by_name(paper, "full", 1).spec().steps == 5760
    assert len({r.folder for r in full}) == len(full)
    # the zone the medium map chose goes to paper scale at its velocity
    box = sp.Config("medium", 40.0, "coupled", zone="box", de_zone=0.5)
    chosen = sp.plan("full", only="paper", paper_choice={40.0: box})
    assert {r.config.name for r in chosen if r.config.group == "paper-40ms"} == {
        "full", "box-0.5m"}
    assert {r.config.name for r in chosen if r.config.group == "paper-10ms"} == {
        "full", "grown"}


def test_the_default_plan_fits_its_budget_and_the_full_sweep_is_larger():
    cost = lambda runs: (sum(sp.run_cost(r, BENCH) for r in runs)   # noqa: E731
                         + sp.timing_cost(runs, BENCH))
    assert cost(sp.plan("default")) <= sp.BUDGET_S < cost(sp.plan("full"))


def test_the_cost_model_reproduces_the_benchmark_models():
    from cases.slab import SlabSpec
    for scale in ("small", "medium", "paper"):
        spec = SlabSpec(scale=scale)            # the benchmark's coupled model: the default
        b = BENCH[scale]["coupled"]
        spheres, bridging, nodes = sp.counts(spec, BENCH[scale]["full"]["n_spheres"])
        assert spheres == pytest.approx(b["n_spheres"], rel=0.03)
        assert bridging == pytest.approx(b["n_bridging_spheres"], rel=0.05)
        assert nodes == b["n_fe_nodes"]


def test_the_table_judges_each_zone_as_compare_does(forty, capsys):
    """The box 1.01 × its pair: equivalent on all 23 statistics and 6× cheaper: it
    qualifies. The grown zone 1.2 × its pair: +20 % on every peak, not equivalent: it
    fails, each failure named. Both judgements are `compare`'s, headline for headline."""
    runs, out = forty
    table = st.build(runs, out)
    box, grown = row(table, "box-0.5m"), row(table, "grown")
    assert box["judged"]["equivalent"] == box["judged"]["total"] == 23
    assert box["speedup"] == {"runs": 6.0, "value": 6.0,
                              "source": st.SPEEDUP_SOURCES["runs"]}
    assert box["goal"] == {"qualifies": True, "equivalent": True, "cheap_enough": True,
                           "why": "equivalent on all 23; 6.00x >= 5x per step"}
    assert box["sphere_ratio"] == pytest.approx(10 / 6)
    assert grown["goal"]["qualifies"] is False and grown["goal"]["equivalent"] is False
    assert grown["goal"]["why"] == "16 not equivalent of 23; 3.00x < 5x per step"
    assert len(grown["judged"]["failures"]["not equivalent"]) == 16
    assert grown["judged"]["failures"]["not equivalent"][0].startswith(
        "impactor_z peak (+20.0% [")
    assert grown["conversions"] == [1, 1, 1, 1]
    for name in ("box-0.5m", "grown"):
        assert main(["compare", str(out / "medium-40ms" / "full"),
                     str(out / "medium-40ms" / name), "--out", str(out / f"cmp-{name}")]) == 0
        cmp = json.loads((out / f"cmp-{name}" / "comparison.json").read_text())
        assert cmp["headline"] == row(table, name)["judged"]["headline"]
    # the paper scale takes the box, the one that qualifies at 40 m/s
    assert st.choose(table) == {40.0: sp.Config("paper", 40.0, "coupled", zone="box",
                                                 de_zone=0.5)}


def test_a_wide_spread_leaves_the_goal_undecided_and_a_limit_says_cannot_pay(tmp_path):
    """Pair differences of ± 0.4: the peaks cannot judge, so the goal is undecided, however
    cheap; a grown zone stopped at its limit on one seed: coupling cannot pay; a zone with
    one finished member: not judged, undecided."""
    runs = runs_at(40.0)
    members(tmp_path, runs, "full", FULL, s_per_step=3.0)
    members(tmp_path, runs, "box-0.5m", {1: 1.38, 2: 0.6, 3: 1.42, 4: 0.6}, s_per_step=0.5)
    members(tmp_path, runs, "grown", {1: 1.0, 2: 1.0, 3: 1.0}, s_per_step=0.5)
    g4 = by_name(runs, "grown", 4)
    write_limit(tmp_path / g4.folder, g4)
    table = st.build(runs, tmp_path)
    box = row(table, "box-0.5m")
    assert box["goal"]["qualifies"] is None and box["goal"]["equivalent"] is None
    assert box["goal"]["why"] == "16 cannot judge of 23; 6.00x >= 5x per step"
    assert box["judged"]["failures"]["cannot judge"][0].startswith(
        "impactor_z peak (needs ")
    assert row(table, "grown")["goal"] == {
        "qualifies": False, "equivalent": None, "cheap_enough": True,
        "why": "cannot pay: the grown zone reached its limit on seed(s) 4"}
    assert st.choose(table) == {}
    one = sp.plan(only="medium", velocities=[10.0])
    members(tmp_path, one, "full", FULL)
    members(tmp_path, one, "box-0.5m", {1: 1.0}, s_per_step=0.1)
    lone = st.build(one, tmp_path)["impacts"][0]["configs"][0]
    assert lone["goal"]["qualifies"] is None
    assert "needs 2 same-seed pairs or 2 members of each model" in lone["goal"]["why"]


def test_finished_runs_are_reused_here_or_from_an_ensemble(tmp_path, capsys):
    runs = runs_at(40.0)
    f1, f2 = by_name(runs, "full", 1), by_name(runs, "full", 2)
    write_member(tmp_path / "study" / f1.folder, f1, 1.0)
    # make validate's layout: results/slab-medium/full/seed-N
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
    assert lines["medium-40ms/grown/seed-4"].endswith("to run")


def test_reuse_ignores_only_what_cannot_act_on_the_model():
    """A full run made under another relaxation or FE modulus is the same full run; one of
    another seed, or a reinforced one under another fc (the bars' bond), is not; a coupled
    run under another relaxation is not."""
    full = asdict(sp.Config("medium", 10.0, "full").spec(1))
    key = lambda spec, model="full": sp.spec_key(spec, model)     # noqa: E731
    assert key({**full, "relaxation": 48.9, "relaxation_rule": "auto: ...",
                "young": 2e10}) == key(full)
    assert key({**full, "seed": 2}) != key(full)
    bars = asdict(sp.Config("medium", 10.0, "full", reinforced=True).spec(1))
    assert key({**bars, "compressive_strength": 1e7}) != key(bars)
    assert key({**full, "compressive_strength": 1e7}) == key(full)
    box = asdict(sp.Config("medium", 10.0, "coupled", zone="box", de_zone=0.5).spec(1))
    assert key({**box, "relaxation": 48.9}, "coupled") != key(box, "coupled")


@pytest.mark.parametrize("args, message", [
    (["--velocities", "30"], "velocity 30.0 m/s is not one of the study's (10, 20, 40 m/s)"),
    (["--reuse-ensembles", "/nonexistent-study-folder"], "no such folder"),
    (["--seeds", "1"], "--seeds 1: the yardstick needs 2 or more distinct seeds"),
    (["--paper-seeds", "2,2"], "--paper-seeds 2,2: the yardstick needs 2 or more distinct"),
    (["--scale", "paper"], "--scale must be small or medium, got 'paper'"),
    (["--only", "paper"], "--only paper runs nothing without paper seeds"),
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


def test_plots_and_page_follow_the_table(forty):
    runs, out = forty
    table = st.build(runs, out)
    table["table1"] = None
    report.plot_impact(table["impacts"][0], out / "p.png")
    assert (out / "p.png").stat().st_size > 0
    outcomes = execute(runs, out, {}, log=lambda line: None, dry=True)
    assert {o.status for o in outcomes.values()} == {"done"}
    text = report.doc(table, runs, outcomes, 3600.0, "default", {}, "study")
    assert ("- **medium scale, 40 m/s, box-0.5m** (seeds 1, 2, 3, 4): equivalent on all 23; "
            "6.00x >= 5x per step") in text
    md = report.markdown(table)
    assert "| box-0.5m | 1,2,3,4 | 6 | 1.67 | 6.00 (runs) | 23 of 23 | 0 | – | none |" in md
    assert "| grown (1-1 conversions) | 1,2,3,4 | 6 | 1.67 | 3.00 (runs) | 7 of 23 | 0 | – | " \
           "**impactor_z peak (+20.0% [" in md
    # without the qualifying zone: nowhere shown, each zone's verdict given
    row(table, "box-0.5m")["goal"]["qualifies"] = None
    text = report.doc(table, runs, outcomes, 3600.0, "default", {}, "study")
    assert "**Nowhere shown.**" in text
    assert "- medium scale, 40 m/s, grown: no: 16 not equivalent of 23; 3.00x < 5x" in text


@pytest.mark.slow
def test_an_interrupted_run_of_the_study_carries_on_from_its_checkpoint(tmp_path):
    """A coupled run that left a checkpoint at step 40 of 60 (its results removed, as if it
    had been stopped there) is carried on, not started again, and ends as the whole run did."""
    from cases.slab.study.runs import run_one
    from orchestrator.run.outputs import read_sensors
    r = sp.Planned(sp.Config("small", 40.0, "coupled", zone="box", de_zone=0.5), 1, 60)
    folder = tmp_path / r.folder
    assert main(["slab", "--model", "coupled", "--scale", "small", "--steps", "60",
                 "--zone", "box", "--de-zone", "0.5", "--fe-material", "damage",
                 "--checkpoint-every", "20", "--threads", "1", "--out", str(folder),
                 "--quiet"]) == 0
    _, _, whole = read_sensors(folder / "sensors.csv")
    for name in ("summary.json", "sensors.csv", "damage.npz"):
        (folder / name).unlink()
    run_one(r, folder, quiet=True, log=lambda line: None)
    assert "resumed from the checkpoint of step 40" in (folder / "run.log").read_text()
    _, _, carried_on = read_sensors(folder / "sensors.csv")
    assert np.array_equal(whole, carried_on)
