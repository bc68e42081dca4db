"""A slab whose DE zone grows during the run (`slab --zone grow`) checkpoints and resumes as a
fixed zone's run does (tests/test_restart.py): stopped by SIGTERM at a checkpoint taken after
conversions, and resumed, it converts again at the same steps, by the same cells, and ends
with the same zone, damage and sensors as the run that was not stopped.

Bit for bit on one thread until a contact that did not exist at the checkpoint forms (YADE's
`O.save` keeps only the real interactions; after the load the collider makes its candidate
pairs again at the end of the interaction container, so a new contact's forces are summed in
another order: docs/case-files.md). In the case as it was on 2026-12-05 (260 steps, the
FE read in the band too) one formed 3 steps after the resume: from then on the two runs
differed by round-off (sphere states 1e-13 in their velocities by step 240, positions
2.8e-17 m at step 260; sensors.csv, written to 10 digits, identical).
The test asserts exact equality where round-off cannot reach (the conversions' steps, cells
and counts, the zone, the broken links, every frame up to the checkpoint) and bounds the rest
(sensors within 1e-9 of their peaks, energies within 1e-12).

A checkpoint whose case changed, or whose growth does not fit the case, is refused with one
line, before anything is built."""
import json
import os
import shutil
import signal

import meshio
import numpy as np
import pytest

from cli.main import STOPPED, main
from orchestrator.run.outputs import QUANTITIES, read_quantities, read_sensors
from yade_side.output import read_series

# the small slab at 40 m/s from the 0.5 m box: band links break at once, and the zone grows at
# steps 200 and 300 (measured on 2026-12-06; the test asserts only that some come before the
# checkpoint of STOP_AT and some after); the checkpoint of step 200 is taken after the
# conversion of that step
GROW = ["slab", "--model", "coupled", "--scale", "small", "--impactor-speed", "40",
        "--zone", "grow", "--zone-start", "0.5", "--layers", "1", "--fe-material", "damage",
        "--links-every", "100", "--trip-omega", "1", "--trip-damage", "0.9", "--steps", "310",
        "--checkpoint-every", "100", "--output-every", "50", "--threads", "1", "--quiet"]
STOP_AT = 200


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The run not stopped; the same run stopped by SIGTERM right after its checkpoint of step
    STOP_AT (not yet resumed); and the checkpoint it wrote at step 100, before any conversion,
    set aside."""
    from orchestrator.run.record import Recorder
    top = tmp_path_factory.mktemp("grow-resume")
    reference, stopped = top / "reference", top / "stopped"
    assert main(GROW + ["--out", str(reference)]) == 0
    checkpoint = Recorder.checkpoint

    def checkpoint_then_sigterm(self, n):
        checkpoint(self, n)
        if n == 100:
            shutil.copytree(self.out / "checkpoint", top / "checkpoint-100")
        if n == STOP_AT:
            os.kill(os.getpid(), signal.SIGTERM)    # as `kill PID` would, after this step
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Recorder, "checkpoint", checkpoint_then_sigterm)
        assert main(GROW + ["--out", str(stopped)]) == STOPPED
    return reference, stopped, top / "checkpoint-100"


def same_bits(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


@pytest.mark.parametrize("step", [STOP_AT, pytest.param(100, marks=pytest.mark.slow)])
def test_a_grown_run_resumed_ends_as_the_run_not_stopped(runs, tmp_path, step):
    """Resumed from the checkpoint of step 200, taken after the first conversion (at that very
    step), as stopped by SIGTERM; or from the one of step 100, before any, as a run
    killed at step 200 would be (its series and FE files hold frames past the checkpoint)."""
    reference, stopped, checkpoint_100 = runs
    out = tmp_path / "run"
    shutil.copytree(stopped, out)
    if step == 100:
        shutil.rmtree(out / "checkpoint")
        shutil.copytree(checkpoint_100, out / "checkpoint")
    sa = json.loads((reference / "summary.json").read_text())
    steps = [c["step"] for c in sa["zone_conversions"]]
    # the case as it must be: conversions before the checkpoint of STOP_AT and after it
    assert steps and steps[0] <= STOP_AT < steps[-1], f"conversions at steps {steps}"
    meta = json.loads((out / "checkpoint" / "meta.json").read_text())
    growth = json.loads((out / "checkpoint" / "model.json").read_text())
    assert meta["step"] == step and not (out / "summary.json").exists()
    assert [c["step"] for c in growth["conversions"]] == [n for n in steps if n <= step]
    assert meta["n_spheres"] == (growth["conversions"][-1]["spheres"] if growth["conversions"]
                                 else sa["zone_segments"][0]["spheres"])   # the zone's model
    assert main(["slab", "--resume", str(out), "--quiet"]) == 0

    sb = json.loads((out / "summary.json").read_text())
    # the same zone, grown at the same steps by the same cells after the checkpoint too
    assert sb["zone_outcome"] == sa["zone_outcome"] == "clean"
    assert sb["zone_final"] == sa["zone_final"]
    exact = ("step", "indicator", "cells", "zone_cells", "spheres_added", "spheres")
    for ca, cb in zip(sa["zone_conversions"], sb["zone_conversions"], strict=True):
        assert {k: cb[k] for k in exact} == {k: ca[k] for k in exact}
        stretch_a, stretch_b = ca["carried"].pop("stretch"), cb["carried"].pop("stretch")
        assert cb["carried"] == ca["carried"]          # the counts
        # |c − 1| ~ 1e-3 from distances equal to the 1e-12 of the state: 1e-9 of it
        assert np.isclose(stretch_b, stretch_a, rtol=1e-9, atol=0)
        assert np.isclose(cb["energy_after"], ca["energy_after"], rtol=1e-12, atol=0)
    for key in ("zone_segments", "zone_sphere_steps", "n_spheres"):
        assert sb[key] == sa[key], key
    for name, sensor in sa["sensors"].items():
        assert sb["sensors"][name]["position"] == sensor["position"]
        assert np.isclose(sb["sensors"][name]["peak_displacement"],
                          sensor["peak_displacement"], rtol=1e-9, atol=0)
    assert sb["damage"]["broken_links"] == sa["damage"]["broken_links"] > 0
    ea, eb = np.array(sa["energy"]), np.array(sb["energy"])
    assert same_bits(ea[:, 0], eb[:, 0]) and np.allclose(eb, ea, rtol=1e-12, atol=0)
    (ta, na, ha), (tb, nb, hb) = (read_sensors(d / "sensors.csv") for d in (reference, out))
    assert na == nb and same_bits(ta, tb)
    peak = np.abs(ha).max(axis=(0, 2))
    assert peak.min() > 1e-6                                  # every sensor moved
    assert (np.abs(hb - ha).max(axis=(0, 2)) <= 1e-9 * peak).all()
    # the QoIs alike; the forces unmeasured at t = 0, the reaction at the first sample after
    # each conversion (sample_every: 5)
    (ta, na, qa), (tb, nb, qb) = (read_quantities(d / QUANTITIES) for d in (reference, out))
    assert na == nb and same_bits(ta, tb)
    assert np.flatnonzero(np.isnan(qa[:, na.index("contact_force")])).tolist() == [0]
    assert np.flatnonzero(np.isnan(qa[:, na.index("reaction")])).tolist() == \
        [0, *sorted({-(-n // 5) for n in steps})]
    assert np.array_equal(np.isnan(qa), np.isnan(qb))
    peak = np.nanmax(np.abs(qa), axis=0)
    assert (np.nanmax(np.abs(qb - qa), axis=0) <= 1e-9 * peak).all()
    da, db = np.load(reference / "damage.npz"), np.load(out / "damage.npz")
    for key in da.files:
        # FE damage 2e-12; a link's cracking energy within 1e-9 of the largest (3e-11 J on
        # 0.5 J: its κ carries the states' round-off, which a small energy does not scale)
        atol = 1e-9 * np.abs(da[key]).max() if key == "crack_energy" else 1e-12
        assert np.allclose(db[key], da[key], rtol=1e-9, atol=atol), key
    # every frame of the spheres: bit for bit up to the checkpoint, then within round-off
    (t_ref, spheres_ref), (t_out, spheres_out) = (
        zip(*read_series(d / "spheres.pvd")) for d in (reference, out))
    assert t_ref == t_out
    for t, m1, m2 in zip(t_ref, spheres_ref, spheres_out, strict=True):
        if t <= step * sa["dt"] * (1 + 1e-9):
            assert same_bits(m1.points, m2.points)
        assert np.abs(m1.points - m2.points).max() < 1e-12
        assert same_bits(m1.point_data["damage"], m2.point_data["damage"])
    # the FE series: the file of the checkpoint's zone goes on after its frames, the next
    # zone's is written anew
    frames, names = 0, sorted(f.name for f in reference.glob("fe*.xdmf"))
    assert names == sorted(f.name for f in out.glob("fe*.xdmf")) and len(names) > 2
    for name in names:
        with meshio.xdmf.TimeSeriesReader(reference / name) as ra, \
                meshio.xdmf.TimeSeriesReader(out / name) as rb:
            ra.read_points_cells(), rb.read_points_cells()
            assert ra.num_steps == rb.num_steps > 0, name
            frames += ra.num_steps
            for k in range(ra.num_steps):
                (t1, p1, c1), (t2, p2, c2) = ra.read_data(k), rb.read_data(k)
                assert t1 == t2
                assert np.abs(p1["displacement"] - p2["displacement"]).max() < 1e-12
                assert np.abs(c1["damage"][0] - c2["damage"][0]).max() < 1e-9
    assert frames == len(da["times"])


def one_line_error(capsys, code):
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    return err


def test_a_grown_run_whose_case_changed_is_refused(runs, tmp_path, capsys):
    """Before anything is built: a spec changed since the checkpoint (each difference named),
    a growth that does not fit the case, an unreadable one."""
    out = tmp_path / "run"
    shutil.copytree(runs[1], out)
    meta_path = out / "checkpoint" / "meta.json"
    meta = json.loads(meta_path.read_text())
    changed = json.loads(json.dumps(meta))
    changed["info"]["spec"]["trip_omega"] = 0.5
    meta_path.write_text(json.dumps(changed))
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "the case changed since the checkpoint" in err
    assert "trip_omega: 1.0 at the checkpoint, 0.5 now" in err
    meta_path.write_text(json.dumps(meta))

    model = out / "checkpoint" / "model.npz"
    saved = dict(np.load(model))
    zones = saved["zones"].copy()
    zones[0] = zones[1]                                 # not the start zone
    np.savez(model, **{**saved, "zones": zones})
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "does not fit the case (its first zone is not the case's start zone)" in err
    np.savez(model, **{**saved, "zones": saved["zones"][:, :-1]})
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "its zones are masks of shape" in err
    model.write_bytes(b"not a zip")
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "unreadable checkpoint file, the model's own state" in err
    model.unlink()
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "no model.npz in it" in err
    assert not (out / "summary.json").exists()


# the same slab with a budget so small that the zone stops at its first trip (broken band
# links read every 50 steps: step 150), and the full model it falls back to, checkpointed at
# step 100 (a checkpoint of the small full slab takes about 10 s)
LIMITED = ["slab", "--model", "coupled", "--scale", "small", "--impactor-speed", "40",
           "--fe-material", "damage", "--zone-cost", "0.05", "--fallback", "full",
           "--links-every", "50", "--trip-omega", "1",
           "--steps", "160", "--checkpoint-every", "100", "--output-every", "100",
           "--threads", "1", "--quiet"]


@pytest.mark.slow
def test_a_fallback_stopped_resumes_and_ends_as_the_run_not_stopped(tmp_path):
    """A grown run whose zone reached its budget runs the full model (`--fallback full`);
    stopped by SIGTERM during it (after its checkpoint of step 100), `slab --resume` carries
    the full model on from there and writes the summary the run not stopped wrote: the growth
    record of stopped/, the full model's figures (bit-identical to where round-off can
    reach: a full slab resumed is, until a new contact forms, docs/case-files.md)."""
    from orchestrator.run.record import Recorder
    reference, out = tmp_path / "reference", tmp_path / "stopped"
    assert main(LIMITED + ["--out", str(reference)]) == 0
    checkpoint = Recorder.checkpoint

    def checkpoint_then_sigterm(self, n):
        checkpoint(self, n)
        if self.out.name == "full" and n == 100:
            os.kill(os.getpid(), signal.SIGTERM)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Recorder, "checkpoint", checkpoint_then_sigterm)
        assert main(LIMITED + ["--out", str(out)]) == STOPPED
    assert (out / "stopped" / "growth.json").is_file() and (out / "full" / "checkpoint").is_dir()
    assert not (out / "summary.json").exists()
    assert main(["slab", "--resume", str(out), "--quiet"]) == 0
    assert not (out / "full").exists()
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (reference, out))
    assert sa["zone_outcome"] == sb["zone_outcome"] == "limit"
    assert sa["zone_fallback"] == sb["zone_fallback"] == "full" and sb["model"] == "full"
    growth = ("zone_conversions", "zone_final", "zone_segments", "zone_sphere_steps",
              "zone_message", "zone_limit_reached", "zone_full_model_spheres")
    assert {k: sb[k] for k in growth} == {k: sa[k] for k in growth}
    assert sa["zone_wall_s"] > 0 and sb["zone_wall_s"] > 0       # each process's to its limit
    assert sb["n_spheres"] == sa["n_spheres"] and sb["steps"] == sa["steps"] == 160
    for name, sensor in sa["sensors"].items():
        assert np.isclose(sb["sensors"][name]["peak_displacement"],
                          sensor["peak_displacement"], rtol=1e-9, atol=0)
    assert sorted(p.name for p in (out / "stopped").iterdir()) == \
        sorted(p.name for p in (reference / "stopped").iterdir())
    (ta, _, ha), (tb, _, hb) = (read_sensors(d / "sensors.csv") for d in (reference, out))
    assert same_bits(ta, tb) and np.abs(hb - ha).max() <= 1e-9 * np.abs(ha).max()


def test_a_fallback_stopped_is_resumed_by_slab_only(tmp_path, capsys):
    """A folder whose zone reached its limit and whose fallback stopped: `run --resume` names
    the command that carries it on; an unreadable growth record is one line too."""
    out = tmp_path / "run"
    (out / "stopped").mkdir(parents=True)
    (out / "full").mkdir()
    (out / "stopped" / "growth.json").write_text(json.dumps({"spec": {"scale": "small"},
                                                             "zones": []}))
    err = one_line_error(capsys, main(["run", "--resume", str(out), "--quiet"]))
    assert f"carry it on with `slab --resume {out}`" in err
    (out / "stopped" / "growth.json").write_text("{")
    err = one_line_error(capsys, main(["slab", "--resume", str(out), "--quiet"]))
    assert "growth.json: unreadable" in err
