"""The slab variants' measurement (cases.slab.variants) on synthetic run folders whose figures
are known, and the `concrete` choice of the slab (cases.slab.spec)."""
import json
import math

import numpy as np
import pytest

from cases.slab.links import DAMAGED_OMEGA, link_record
from cases.slab.variants import measure_folders
from common.files import save_npz, write_json
from cli.main import main
from orchestrator.run.outputs import write_sensors

R = 0.01
VOLUME = 4.0 / 3.0 * math.pi * R**3


def test_link_record_counts_the_damaged_links_outside():
    """6 links: ω 0, 0.05, 0.1 (not beyond the level), 0.3, 1 (broken), 1; outside: the 2nd,
    4th, 5th. Damaged (ω > 0.1): links 4, 5, 6, of which 4 and 5 outside: share 2/3."""
    omega = [0.0, 0.05, DAMAGED_OMEGA, 0.3, 1.0, 1.0]
    outside = [False, True, False, True, True, False]
    assert link_record(omega, outside) == {
        "level_omega": DAMAGED_OMEGA, "links": 3, "links_total": 6, "damaged": 2,
        "damaged_total": 3, "broken": 1, "broken_total": 2, "damaged_share_outside": 2 / 3}
    assert link_record([0.0, 0.0], [True, False])["damaged_share_outside"] is None
    with pytest.raises(ValueError, match="2 damages for"):
        link_record([0.0, 0.0], [True])


def fake_run(folder, model="full", seed=1, concrete="gf", links=True):
    """A slab results folder: 4 spheres of radius R, final damage 1, 0.5, 0, 0.25, the first
    two in the DE zone (damaged volume 1.75 V, outside 0.25 V); the under-impact sensor goes
    down to −40 mm at t = 2 ms and comes back to −30 mm at 4 ms, at 2.5 m/s upwards."""
    folder.mkdir(parents=True)
    t = np.linspace(0.0, 4e-3, 401)
    z = np.where(t <= 2e-3, -0.04 * t / 2e-3, -0.04 + 2.5 * (t - 2e-3))
    history = np.zeros((len(t), 2, 3))
    history[:, 0, 2] = z
    history[:, 1, 2] = -0.001
    write_sensors(folder / "sensors.csv", ["under_impact", "de_zone"], t, history)
    save_npz(folder / "damage.npz", times=np.array([0.0, 4e-3]),
             damage=np.array([[0.0] * 4, [1.0, 0.5, 0.0, 0.25]]),
             positions=np.zeros((4, 3)), radius=np.full(4, R),
             in_de_zone=np.array([True, True, False, False]), slab_index=np.arange(4))
    summary = {"model": model, "seed": seed,
               "spec": {"scale": "small", "seed": seed, "de_zone": 0.6, "full_width": True,
                        **({} if concrete is None else {"concrete": concrete})},
               "damage": {"damaged_volume_m3": 1.75 * VOLUME}}
    if links:
        summary["links_outside_de_zone"] = link_record([0.0, 0.5, 1.0, 0.2],
                                                       [True, True, False, False])
    write_json(folder / "summary.json", summary)
    return folder


def test_measure_gives_the_known_figures(tmp_path):
    fake_run(tmp_path / "ens" / "seed-2", seed=2)
    fake_run(tmp_path / "ens" / "seed-1", seed=1)
    fake_run(tmp_path / "old", concrete=None, links=False)     # before the choice: plain
    rows = measure_folders([tmp_path / "ens", tmp_path / "old"])
    assert [(r["seed"], r["variant"]) for r in rows] == [(1, "gf"), (2, "gf"), (1, "plain")]
    r = rows[0]
    assert r["peak_under_impact_m"] == pytest.approx(0.04, rel=1e-9)
    assert r["peak_time_s"] == pytest.approx(2e-3, rel=1e-9)
    assert r["end_under_impact_m"] == pytest.approx(-0.035, rel=1e-9)
    assert r["end_speed_under_impact_m_s"] == pytest.approx(2.5, rel=1e-6)
    assert r["damaged_volume_m3"] == pytest.approx(1.75 * VOLUME, rel=1e-12)
    assert r["damaged_volume_share_outside"] == pytest.approx(1 / 7, rel=1e-12)
    # links: damaged 0.5, 1.0, 0.2; outside the first only
    assert r["damaged_links_share_outside"] == pytest.approx(1 / 3, rel=1e-12)
    assert rows[2]["links_outside_de_zone"] is None and rows[2]["damaged_links_share_outside"] is None


def test_the_variants_command_prints_the_table_and_refuses_a_coupled_run(tmp_path, capsys):
    fake_run(tmp_path / "full")
    assert main(["variants", str(tmp_path / "full"), "--json", str(tmp_path / "v.json")]) == 0
    out = capsys.readouterr().out
    assert "| gf | small | 1 | 40.0 | 2.00 | 2.50 |" in out and "14.3 % | 33.3 % (1 of 3) |" in out
    assert json.loads((tmp_path / "v.json").read_text())[0]["seed"] == 1
    fake_run(tmp_path / "coupled", model="coupled")
    assert main(["variants", str(tmp_path / "coupled")]) == 2
    assert "'coupled' slab run" in capsys.readouterr().err
    assert main(["variants", str(tmp_path / "nothing")]) == 2
    assert "not a slab results folder" in capsys.readouterr().err


def test_the_slab_takes_the_gf_set_of_its_scale():
    """concrete "gf": the scale's Gf set and its measured material (ν, fc, ft, Gf of its
    calibration record), and as many more steps as the stiffer spheres shorten the critical
    step (∝ 1/√young), so that the run lasts as long: the impact's duration at the scale
    (its table's 7 ms, or the measured one of the impact speed)."""
    from cases.slab import SCALES, SlabSpec, concrete as params_of
    from cases.slab.scales import STEPS_SAFETY, TABLE_DURATION, concrete_set, duration as window
    for scale in ("small", "medium"):
        table, gf, plain_set = SCALES[scale], concrete_set(scale, "gf"), concrete_set(scale, "plain")
        spec = SlabSpec(scale=scale, concrete="gf")
        steps = table.steps * window(scale, spec.impactor_speed) / TABLE_DURATION
        assert spec.cpm == gf.cpm
        assert (spec.poisson, spec.compressive_strength, spec.tensile_strength,
                spec.fracture_energy) == (gf.poisson, gf.compressive_strength,
                                          gf.tensile_strength, gf.fracture_energy)
        # the table's steps are at STEPS_SAFETY × the critical step
        duration = lambda steps, cpm, safety: steps * safety / math.sqrt(cpm["young"])
        assert duration(spec.steps, gf.cpm, spec.dt_safety) == pytest.approx(
            duration(steps, plain_set.cpm, STEPS_SAFETY), rel=1 / spec.steps)
        params = params_of(spec)
        assert (params.relDuctility, params.equivStrainShearContrib) == (0.1, 0.1)
        plain = SlabSpec(scale=scale)
        assert (plain.cpm, plain.tensile_strength, plain.steps) == (
            plain_set.cpm, plain_set.tensile_strength,
            math.ceil(round(steps * STEPS_SAFETY / plain.dt_safety, 6)))
        assert params_of(plain).equivStrainShearContrib == 0.0
    given = SlabSpec(concrete="gf", tensile_strength=3e6, steps=10)
    assert (given.tensile_strength, given.steps) == (3e6, 10)


def test_bad_concrete_choices_are_refused_in_one_line(tmp_path, capsys):
    from cases.slab import SlabSpec
    with pytest.raises(ValueError, match="^slab: concrete 'gf' has no calibrated set at scale "
                                         "'paper' \\(only small, medium\\)$"):
        SlabSpec(scale="paper", concrete="gf")
    with pytest.raises(ValueError, match="concrete must be one of 'plain', 'gf', got 'steel'"):
        SlabSpec(concrete="steel")
    assert main(["slab", "--model", "full", "--scale", "paper", "--concrete", "gf",
                 "--out", str(tmp_path / "x")]) == 2
    assert capsys.readouterr().err.startswith("error: slab: concrete 'gf' has no calibrated")
    assert not (tmp_path / "x").exists()


def test_the_case_file_key_is_material_concrete(tmp_path):
    from cases.kinds import load_case
    from cases.slab.casefile import spec
    from orchestrator.casefile import CaseError
    path = tmp_path / "s.toml"
    path.write_text('[case]\nkind = "slab"\n[slab]\nmodel = "full"\n[material]\n'
                    'concrete = "gf"\n')
    assert spec(load_case(path)).concrete == "gf"
    path.write_text('[case]\nkind = "slab"\n[slab]\nmodel = "full"\n[material]\n'
                    'concrete = "rc"\n')
    with pytest.raises(CaseError, match="material.concrete = 'rc': expected one of"):
        load_case(path)


def test_compare_refuses_runs_of_two_concretes(tmp_path):
    """A coupled gf run is not compared with a full plain one; a run made before the concrete
    choice existed is plain."""
    from cases.slab.compare import load
    fake_run(tmp_path / "full-old", concrete=None)
    fake_run(tmp_path / "coupled-gf", model="coupled", concrete="gf")
    fake_run(tmp_path / "coupled-plain", model="coupled", concrete="plain")
    with pytest.raises(ValueError, match="members differ in concrete: 'plain' .* vs 'gf'"):
        load([tmp_path / "full-old"], [tmp_path / "coupled-gf"])
    full, coupled = load([tmp_path / "full-old"], [tmp_path / "coupled-plain"])
    assert full[1].spec["concrete"] == coupled[1].spec["concrete"] == "plain"


def test_the_paper_set_takes_its_gf_from_its_separation_test_at_the_slabs_step(tmp_path,
                                                                               monkeypatch):
    """The paper record has no Gf (its balance failed at the calibration's step); the same
    set's separation test at the slab's step closes its balance within CLOSURE and gives it
    (a lower bound: not separated). A separation record of other params is refused."""
    from cases.slab import scales
    from yade_side.fracture import CLOSURE
    record = json.loads((scales.CALIBRATIONS / "paper-plain.json").read_text())
    test = json.loads((scales.CALIBRATIONS / "paper-plain-separation.json").read_text())
    assert record["measured"]["fracture_energy"] is None and test["params"] == record["params"]
    assert abs(test["separation"]["closure"]) <= CLOSURE and not test["separation"]["separated"]
    paper = scales.concrete_set("paper", "plain")
    assert paper.fracture_energy == test["measured"]["fracture_energy"]
    assert paper.compressive_strength == record["measured"]["fc"]     # the rest: the record's
    monkeypatch.setattr(scales, "CALIBRATIONS", tmp_path)
    scales.concrete_set.cache_clear()
    try:
        (tmp_path / "paper-plain.json").write_text(json.dumps(record))
        test["params"]["young"] *= 2
        (tmp_path / "paper-plain-separation.json").write_text(json.dumps(test))
        with pytest.raises(ValueError, match=r"paper-plain-separation\.json: params are not "
                                             r"those of paper-plain\.json"):
            scales.concrete_set("paper", "plain")
    finally:
        scales.concrete_set.cache_clear()
