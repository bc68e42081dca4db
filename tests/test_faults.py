"""Bad input and faults: a run never deletes what it did not write, every bad input gets a
non-zero exit and one line naming the file, key or position and the value (never a
traceback), a resumed run refuses a changed case, and what used to be snapped or accepted
silently is refused or warned about with the distance (docs/case-files.md)."""
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from cases.generic import CaseModel
from cases.kinds import case_inputs, load_case as load
from common.files import record, save_npz, unrecorded, write_json, write_text
from orchestrator.casefile import CaseError
from cli.main import INTERRUPTED, main
from orchestrator.run.folder import FAILED, MARKER, ResultsExist, prepare_out, settle_failure
from orchestrator.run.restart import check_inputs

ROOT = Path(__file__).resolve().parents[1]
BLOCK = ROOT / "cases" / "block_impact.toml"

# a small coupled case: a 0.6 × 0.6 × 0.1 m plate of 6 × 6 × 1 hexahedra, the DE zone
# [0.2, 0.4]² through it, one bridging layer, free spheres filling zone and band
CASE = """
[de]
script = "{script}"
script_args = {args}
[fe]
lo = [0.0, 0.0, 0.0]
hi = [0.6, 0.6, 0.1]
n = [6, 6, 1]
[coupling]
zone_lo = [0.2, 0.2, 0.0]
zone_hi = [0.4, 0.4, 0.1]
layers = 1
[time]
steps = 30
[output]
every = 5
checkpoint_every = 10
{extra}
"""
SPHERES = """
import sys
from yade import pack
O.bodies.append(pack.regularHexa(pack.inAlignedBox((0.1, 0.1, 0), (0.5, 0.5, 0.1)),
                                 radius=0.02, gap=0.001))
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             NewtonIntegrator(damping=0), PyRunner(command='check()', iterPeriod=1)]
fail_at = int(sys.argv[1]) if len(sys.argv) > 1 else 0


def check():
    if fail_at and O.iter >= fail_at:
        raise RuntimeError(f"the user's check failed at iteration {O.iter}")
"""


def small_case(folder, extra="", script_text=SPHERES, args=(), name="c.toml"):
    script = folder / "s.py"
    script.write_text(script_text)
    case = folder / name
    case.write_text(CASE.format(script=script, args=json.dumps(list(args)), extra=extra))
    return case


def cli(argv):
    """main's exit code, also for argparse's refusals (which exit)."""
    try:
        return main(argv)
    except SystemExit as e:
        return e.code


def one_line_error(capsys, code, expected=2):
    """The command's stderr: exactly one `error:` line (a case file's problems follow it,
    one per line), no traceback."""
    err = capsys.readouterr().err
    assert code == expected, err
    assert "Traceback" not in err
    assert len([line for line in err.splitlines() if line.startswith("error:")]) == 1, err
    return err


# --- results folders ------------------------------------------------------------------------
def test_force_replaces_only_a_results_folder_of_the_project(tmp_path, capsys):
    mine = tmp_path / "notes"
    mine.mkdir()
    (mine / "case.toml").write_text("my notes")
    code = main(["run", str(BLOCK), "--out", str(mine), "--force", "--quiet"])
    assert "was not written by this project" in one_line_error(capsys, code)
    assert (mine / "case.toml").read_text() == "my notes"
    # a results folder holding the run's own case file: --force would delete an input
    results = prepare_out(tmp_path / "results")
    shutil.copy(BLOCK, results / "block.toml")
    (results / "scripts").mkdir()
    shutil.copy(ROOT / "cases" / "scripts" / "block_impact.py", results / "scripts")
    code = main(["run", str(results / "block.toml"), "--out", str(results), "--force"])
    assert "an input of this run: --force would delete it" in one_line_error(capsys, code)
    assert (results / "block.toml").is_file()


def test_force_replaces_only_what_the_project_wrote(tmp_path):
    """The marker lists what the project wrote: files, a folder written whole (a checkpoint),
    a nested results folder's own list, a temporary file a kill left. A file the user added
    stops --force, named; once moved out, --force replaces the folder."""
    run = prepare_out(tmp_path / "run")
    write_json(run / "summary.json", {})
    (run / "checkpoint").mkdir()
    (run / "checkpoint" / "scene.yade.gz").write_bytes(b"")     # written by YADE itself
    record(run / "checkpoint")
    (run / ".summary.json.k2x9_a0q.json").write_text("")          # atomic's, killed
    member = prepare_out(run / "seed-1")
    write_text(member / "run.log", "")
    assert unrecorded(run) == []
    (run / "notes.txt").write_text("mine")
    (member / "analysis").mkdir()
    (member / "analysis" / "fit.py").write_text("mine")
    with pytest.raises(ResultsExist, match=r"holds 2 file\(s\) the project did not write "
                                           r"\(notes.txt, seed-1/analysis/fit.py\)"):
        prepare_out(run, force=True)
    assert (run / "notes.txt").read_text() == "mine" and (run / "summary.json").is_file()
    (run / "notes.txt").unlink()
    shutil.rmtree(member / "analysis")
    prepare_out(run, force=True)
    assert [p.name for p in run.iterdir()] == [MARKER]
    # the marker of an earlier version, which listed nothing: nothing is known to be ours
    (run / "summary.json").write_text("{}")
    (run / MARKER).write_text("results folder written by yade-fenicsx-coupling\n")
    with pytest.raises(ResultsExist, match=r"written by an earlier version, which did not list "
                                           r"its files: --force cannot tell them from yours"):
        prepare_out(run, force=True)


def test_slab_force_never_replaces_the_run_its_zone_comes_from(tmp_path, capsys):
    grown = prepare_out(tmp_path / "grown")
    write_json(grown / "summary.json", {"zone_outcome": "clean", "zone_final": {
        "cells": [[6, 4], [6, 5]], "grid": {"n": [15, 12, 4]}}})
    code = main(["slab", "--model", "coupled", "--zone-from", str(grown), "--out", str(grown),
                 "--force"])
    assert "an input of this run: --force would delete it" in one_line_error(capsys, code)
    assert (grown / "summary.json").is_file()


@pytest.mark.parametrize("spec, args, message", [
    ({"scale": "medium"}, [], "its run has scale 'medium', this one 'small': its zone's cells "
                              "lie on another FE grid"),
    ({}, ["--fe-ratio", "2"], "its run has fe_ratio 3.0, this one 2.0"),
    ({"scale": "small"}, ["--model", "full"], "--zone-from acts only on the coupled model"),
])
def test_a_zone_from_another_grid_or_for_the_full_model_is_refused(tmp_path, capsys, spec, args,
                                                                   message):
    grown = prepare_out(tmp_path / "grown")
    write_json(grown / "summary.json", {
        "zone_outcome": "clean", "spec": {"fe_ratio": 3.0, **spec},
        "zone_final": {"cells": [[6, 4]], "grid": {"n": [15, 12, 4]}}})
    code = main(["slab", "--model", "coupled", "--zone-from", str(grown), *args,
                 "--out", str(tmp_path / "x")])
    assert message in one_line_error(capsys, code)
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("args, message", [
    (["--model", "coupled", "--fe-material", "elastic", "--fracture-energy", "100"],
     "--fracture-energy acts only on the coupled model with fe.material 'damage'"),
    (["--model", "full", "--trip-stress", "3"], "--trip-stress acts only on the coupled model"),
    (["--model", "coupled", "--zone", "box", "--zone-limit", "1.0"],
     "--zone-limit acts only on the coupled model with zone 'auto' or 'grow'"),
    (["--model", "coupled", "--fe-material", "damage", "--trip-stress", "3"],
     "--trip-stress acts only on the coupled model with zone 'auto' or 'grow' and fe.material "
     "'elastic'"),
    (["--model", "full", "--fe-material", "damage"], "--fe-material acts only on the coupled"),
    (["--model", "coupled", "--elastic-outside"], "--elastic-outside acts only on the full"),
    (["--model", "coupled", "--zone", "box", "--grow-shear"],
     "--grow-shear acts only on the coupled model with zone 'grow'"),
])
def test_an_option_that_cannot_act_on_the_run_is_refused(tmp_path, capsys, args, message):
    code = main(["slab", *args, "--out", str(tmp_path / "x")])
    assert message in one_line_error(capsys, code)
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("args, message", [
    (["calibrate", "--no-bending"], "--no-bending acts only with --fe-twin"),
    (["calibrate", "--fe-twin", "--strain-rate", "0.1"],
     "--strain-rate acts on the spheres' tests, not with --fe-twin"),
    (["calibrate", "--measure-only", "--tol", "0.1"], "--tol acts on a fit, not with "
                                                      "--measure-only"),
    (["block3d", "--variants", "full", "--diagonal-relaxation", "10"],
     "--diagonal-relaxation acts only on the diagonal variant's runs"),
])
def test_an_option_its_mode_ignores_is_refused(tmp_path, capsys, args, message):
    code = main([*args, "--out", str(tmp_path / "x")])
    assert message in one_line_error(capsys, code)
    assert not (tmp_path / "x").exists()


def test_a_case_key_that_cannot_act_on_the_run_is_refused(tmp_path, capsys):
    case = tmp_path / "slab.toml"
    case.write_text('[case]\nkind = "slab"\n[slab]\nmodel = "full"\n'
                    '[zone]\ntrip_stress = 3.0\n')
    code = main(["run", str(case), "--out", str(tmp_path / "x")])
    assert f"{case}: zone.trip_stress acts only on the coupled model" in one_line_error(
        capsys, code)
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("out, message", [
    (".", "the current folder or one above it cannot be a results folder"),
    ("..", "the current folder or one above it cannot be a results folder"),
    ("file", "is a file, not a folder"),
    ("file/run", "file is a file, not a folder"),
    ("/proc/run", "cannot write in /proc"),
])
def test_an_out_folder_that_cannot_be_one_is_refused_before_anything_is_built(
        tmp_path, monkeypatch, capsys, out, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("")
    code = main(["run", str(BLOCK), "--out", out, "--force", "--quiet"])
    assert message in one_line_error(capsys, code)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in read-only folders")
def test_a_read_only_out_folder_is_refused_before_anything_is_built(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    code = main(["run", str(BLOCK), "--out", str(locked / "run"), "--quiet"])
    assert "cannot write in" in one_line_error(capsys, code)


def test_a_batch_checks_its_inputs_before_it_touches_its_folder(tmp_path, capsys):
    done = prepare_out(tmp_path / "batch")
    (done / "batch_summary.csv").write_text("name,case,status\n")
    code = cli(["batch", str(BLOCK), "-j", "0", "--force", "--out", str(done)])
    assert "-j/--jobs: must be an integer >= 1, got '0'" in one_line_error(capsys, code)
    assert (done / "batch_summary.csv").is_file()
    code = cli(["batch", str(BLOCK), "-j", "0", "--out", str(tmp_path / "new")])
    one_line_error(capsys, code)
    code = main(["batch", str(tmp_path / "nope.toml"), "--out", str(tmp_path / "new")])
    assert "nope.toml not found" in one_line_error(capsys, code)
    assert not (tmp_path / "new").exists()


def test_a_failed_command_leaves_no_empty_folder_and_marks_the_others_failed(tmp_path):
    empty, started = prepare_out(tmp_path / "empty"), prepare_out(tmp_path / "started")
    (started / "run.log").write_text("...")
    settle_failure("error: something went wrong")
    assert not empty.exists()
    assert (started / FAILED).read_text() == "error: something went wrong\n"
    assert (started / MARKER).is_file() and (started / "run.log").is_file()


@pytest.mark.parametrize("argv, message", [
    (["run", str(BLOCK), "--threads", "0"], "--threads: must be an integer >= 1, got '0'"),
    (["run", str(BLOCK), "--threads", "-2"], "--threads: must be an integer >= 1, got '-2'"),
    (["slab", "--out", "x"], "give --model full|coupled and --out DIR for a new run"),
    (["slab", "--resume", "x", "--layers", "3"], "give no --layers with it"),
    (["run", "--resume", "x", "--force"], "give no case file, --set, --out or --force"),
    (["frobnicate"], "invalid choice: 'frobnicate'"),
])
def test_command_line_mistakes_get_one_line(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    code = cli(argv)
    assert message in one_line_error(capsys, code)
    assert list(tmp_path.iterdir()) == []


# --- files that cannot be read --------------------------------------------------------------
def test_a_case_file_that_is_not_utf8_is_named_with_the_byte_position(tmp_path, capsys):
    case = tmp_path / "c.toml"
    case.write_bytes(b'[case]\nname = "caf\xe9"\n')
    code = main(["run", str(case), "--out", str(tmp_path / "out")])
    err = one_line_error(capsys, code)
    assert f"case file {case} is not UTF-8 text: byte 0xe9 at position 18 (line 2, column 12)" \
        in err
    assert not (tmp_path / "out").exists()


def test_a_case_file_starting_with_a_utf8_byte_order_mark_reads(tmp_path):
    case = small_case(tmp_path)
    case.write_bytes(b"\xef\xbb\xbf" + case.read_bytes())
    assert load(case)["coupling"]["layers"] == 1


def test_a_case_name_that_is_not_a_folder_name_is_refused(tmp_path):
    with pytest.raises(CaseError, match=re.escape(
            "case.name = '../elsewhere': must be a plain folder name")):
        load(small_case(tmp_path), ['case.name="../elsewhere"'])


def test_a_packing_beyond_any_machine_is_refused_before_it_is_made(tmp_path):
    """A radius typed 10 × too small: 1000 × the spheres (0.6 of the box's volume)."""
    text = small_case(tmp_path).read_text().replace(
        f'script = "{tmp_path / "s.py"}"\nscript_args = []',
        "[[de.packing]]\nlo = [0.1, 0.1, 0.0]\nhi = [0.5, 0.5, 0.1]\nradius = 0.0002")
    case = tmp_path / "p.toml"
    case.write_text(text)
    with pytest.raises(CaseError, match=re.escape(
            "de.packing[0].radius = 0.0002: about 2.9e+08 spheres in this box, more than 1e+07")):
        load(case)


@pytest.mark.parametrize("content, message", [
    (b"", " is empty"),
    (b"no mesh here\n", ": meshio cannot read it as a mesh (Error: Couldn't read file"),
])
def test_a_mesh_file_that_holds_no_mesh_is_named(tmp_path, capsys, content, message):
    (tmp_path / "m.msh").write_bytes(content)
    case = small_case(tmp_path)
    text = case.read_text().replace("lo = [0.0, 0.0, 0.0]\nhi = [0.6, 0.6, 0.1]\nn = [6, 6, 1]",
                                    'mesh = "m.msh"')
    case.write_text(text.replace("layers = 1", "layers = 1\nelement_size = 0.1"))
    code = main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"])
    assert f"mesh file {tmp_path / 'm.msh'}{message}" in one_line_error(capsys, code)
    assert not (tmp_path / "out").exists()


# --- users' scripts -------------------------------------------------------------------------
@pytest.mark.parametrize("tail, message", [
    ("O.step(\n", r"s\.py, line \d+: syntax error: '\(' was never closed"),
    ("x = 1 / 0\n", r"s\.py, line 16: ZeroDivisionError: division by zero"),
    ("import sys\nsys.exit(3)\n", r"s\.py, line 17: the script stopped with exit code 3"),
    ("O.engines = O.engines[:3]\nO.step()\n",
     r"s\.py, line 17: RuntimeError: InsertionSortCollider.verletDist>0, but unable to locate "
     r"NewtonIntegrator within O\.engines"),
])
def test_a_script_that_fails_is_named_with_its_line(tmp_path, capsys, tail, message):
    case = small_case(tmp_path, script_text=SPHERES + tail)
    code = main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"])
    assert re.search(r"error: YADE script .*" + message, one_line_error(capsys, code))
    assert not (tmp_path / "out").exists()


def test_a_script_ending_with_exit_ends_its_set_up_there(tmp_path, capsys):
    """YADE scripts often end with exit(): under `yade` it ends the process after the set-up
    and O.run; here the orchestrator runs the time loop, with a note naming the line."""
    case = small_case(tmp_path, script_text=SPHERES + "exit()\nnever = 1\n")
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--quiet"]) == 0
    notes = json.loads((out / "summary.json").read_text())["notes"]
    assert any(re.search(r"s\.py, line 16: exit\(\) ends the script's set-up there", n)
               for n in notes)
    assert json.loads((out / "summary.json").read_text())["steps"] == 30


@pytest.fixture(scope="module")
def failed_run(tmp_path_factory):
    """A run whose script's PyRunner raises in step 26: the folder stays, marked failed, with
    the frames written so far and its checkpoint of step 20."""
    folder = tmp_path_factory.mktemp("failed")
    case = small_case(folder, args=["25"])            # O.iter is 25 during step 26
    out = folder / "run"
    code = main(["run", str(case), "--out", str(out), "--quiet"])
    return case, out, code


def test_a_pyrunner_that_raises_mid_run_stops_it_with_one_line(failed_run, capsys):
    case, out, code = failed_run
    assert code == 2
    failure = (out / FAILED).read_text()
    assert re.fullmatch(r"error: step 26: the PyRunner 'check\(\)' raised RuntimeError: the "
                        r"user's check failed at iteration 25 \(.*s\.py, line 15\)\n", failure)
    assert not (out / "summary.json").exists()
    assert "run stopped: step 26: the PyRunner 'check()'" in (out / "run.log").read_text()
    assert (out / "case.toml").stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_the_paraview_index_lists_every_frame_written(failed_run):
    _, out, _ = failed_run
    listed = [d.get("file") for d in ET.parse(out / "spheres.pvd").getroot().iter("DataSet")]
    written = sorted(f"spheres/{p.name}" for p in (out / "spheres").glob("*.vtu"))
    assert listed == written and len(written) == 6             # steps 0, 5, ..., 25


# --- resuming -------------------------------------------------------------------------------
@pytest.fixture
def stopped(failed_run, tmp_path):
    """A copy of the failed run: its checkpoint (step 20) can be resumed."""
    _, out, _ = failed_run
    copy = tmp_path / "run"
    shutil.copytree(out, copy)
    return copy


def test_resume_refuses_a_changed_case_and_names_each_difference(stopped, capsys):
    case = stopped / "case.toml"
    text = case.read_text()
    assert "layers = 1" in text and 'relaxation = "auto"' in text
    case.write_text(text.replace("layers = 1", "layers = 2")
                        .replace('relaxation = "auto"', "relaxation = 40")
                        .replace('description = ""', 'description = "edited"'))
    code = main(["run", "--resume", str(stopped), "--quiet"])
    err = one_line_error(capsys, code)
    assert "the case changed since the checkpoint" in err
    assert "coupling.layers: 1 at the checkpoint, 2 now" in err
    assert "coupling.relaxation: 'auto' at the checkpoint, 40.0 now" in err
    assert "description" not in err                  # free text changes no result
    assert not (stopped / "summary.json").exists()


def test_resume_refuses_an_edited_script(stopped, capsys):
    script = Path(load(stopped / "case.toml")["de"]["script"])
    original = script.read_text()
    try:
        script.write_text(original.replace("radius=0.02", "radius=0.021"))
        code = main(["run", "--resume", str(stopped), "--quiet"])
        assert re.search(r"content of de\.script: 'sha256:\w+' at the checkpoint, "
                         r"'sha256:\w+' now", one_line_error(capsys, code))
    finally:
        script.write_text(original)


def test_resume_accepts_keys_that_change_no_result(stopped):
    case = load(stopped / "case.toml", ["output.checkpoint_every=7"])
    check_inputs(stopped, case_inputs(case))
    with pytest.raises(ValueError, match=r"output\.every: 5 at the checkpoint, 7 now"):
        check_inputs(stopped, case_inputs(load(stopped / "case.toml", ["output.every=7"])))



def test_a_field_added_since_the_checkpoint_is_the_same_input_at_its_default():
    """A checkpoint written before a SlabSpec field existed carries on at the field's
    declared default, and is refused, naming the field, at any other value."""
    from cases.slab import SlabSpec
    from orchestrator.run.inputs import differences, spec_inputs
    saved = json.loads(json.dumps(spec_inputs(SlabSpec(), "coupled"), default=str))
    del saved["zone_cost"]
    assert differences(saved, spec_inputs(SlabSpec(), "coupled")) == []
    assert differences(saved, spec_inputs(SlabSpec(zone_cost=2.0), "coupled")) == [
        "zone_cost: 0.5 at the checkpoint, 2.0 now"]
    del saved["seed"]                      # a plain dict of inputs has no defaults to fill in
    assert differences(saved, dict(spec_inputs(SlabSpec(), "coupled"))) == [
        "seed: absent at the checkpoint, 1 now", "zone_cost: absent at the checkpoint, 0.5 now"]

@pytest.mark.parametrize("name", ["state.npz", "yade/cpm_history.npz", "meta.json"])
def test_a_corrupt_checkpoint_file_is_named(stopped, capsys, name):
    path = stopped / "checkpoint" / name
    path.write_bytes(path.read_bytes()[:200])
    code = main(["run", "--resume", str(stopped), "--quiet"])
    assert f"{path}: unreadable checkpoint file" in one_line_error(capsys, code)
    assert not (stopped / "summary.json").exists()


def test_a_checkpoint_is_resumed_by_the_command_that_wrote_it(stopped, capsys):
    code = main(["slab", "--resume", str(stopped)])
    assert "not of a slab run: resume it with `run --resume`" in one_line_error(capsys, code)


def test_a_checkpoint_without_the_fe_peak_stress_is_refused_in_one_line(stopped, capsys):
    """A checkpoint of a version that did not record the FE's peak stress: a resumed run's
    post-run check would miss the peak before the checkpoint."""
    state = stopped / "checkpoint" / "state.npz"
    with np.load(state) as data:
        kept = {k: data[k] for k in data.files if k != "fe_peak"}
    np.savez(state, **kept)
    code = main(["run", "--resume", str(stopped), "--quiet"])
    assert "a checkpoint of an earlier version, which did not record the FE's peak stress" \
        in one_line_error(capsys, code)


def test_a_finished_run_is_not_resumed(stopped, capsys):
    (stopped / "summary.json").write_text("{}")
    code = main(["run", "--resume", str(stopped), "--quiet"])
    assert "holds a finished run" in one_line_error(capsys, code)


def test_ctrl_c_finishes_the_step_checkpoints_and_exits_130(tmp_path):
    """SIGINT as SIGTERM: one line, exit code 130, a checkpoint; the run then resumes."""
    case = small_case(tmp_path, script_text=SPHERES + "import time\n"
                      "O.engines = O.engines + [PyRunner(command='time.sleep(0.02)', "
                      "iterPeriod=1)]\n")
    case.write_text(case.read_text().replace("steps = 30", "steps = 60"))
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "cli", "run", str(case), "--out",
                             str(out), "--quiet"], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, OMP_NUM_THREADS="1"))
    meta = out / "checkpoint" / "meta.json"
    while proc.poll() is None and not meta.is_file():
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == INTERRUPTED, err
    assert "Traceback" not in err
    stopped = [line for line in err.splitlines() if line.startswith("stopped:")]
    assert len(stopped) == 1 and "resume with --resume" in stopped[0]
    step = json.loads(meta.read_text())["step"]
    assert 10 <= step < 60 and re.search(rf"stopped at step {step} of 60", stopped[0])
    assert main(["run", "--resume", str(out), "--quiet"]) == 0
    assert json.loads((out / "summary.json").read_text())["steps"] == 60


@pytest.mark.slow
def test_a_stopped_ensemble_stops_its_members_and_starts_no_more(tmp_path):
    """SIGTERM to `slab --seeds`: the running member checkpoints and ends, the next is not
    started, the parent exits 143 in one line; no member is left running."""
    out = tmp_path / "ens"
    proc = subprocess.Popen([sys.executable, "-m", "cli", "slab", "--model", "full", "--scale",
                             "small", "--seeds", "1,2", "--jobs", "1", "--steps", "200",
                             "--checkpoint-every", "20", "--out", str(out), "--quiet"], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, OMP_NUM_THREADS="1"))
    meta = out / "seed-1" / "checkpoint" / "meta.json"
    while proc.poll() is None and not meta.is_file():
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=300)[1]
    assert proc.returncode == 143, err
    assert "Traceback" not in err and err.strip().splitlines()[-1].startswith(
        "stopped: ensemble")
    assert "resume with --resume" in err             # the member's own line
    assert not (out / "seed-2").exists()
    members = subprocess.run(["pgrep", "-f", "--", f"--out {out}/seed-"], capture_output=True)
    assert members.returncode == 1          # none found (2: pgrep could not search)
    assert members.stdout == b""
    # `slab --resume` of the ensemble: seed 1 carries on from its checkpoint, seed 2 runs
    resumed = subprocess.run([sys.executable, "-m", "cli", "slab", "--resume", str(out),
                              "--jobs", "2", "--quiet"], cwd=ROOT, capture_output=True,
                             text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert resumed.returncode == 0, resumed.stderr
    assert f"ensemble {out}: seed 1 carries on; seed 2 runs" in resumed.stdout
    assert "resumed from the checkpoint" in (out / "seed-1" / "run.log").read_text()
    for seed in (1, 2):
        assert json.loads((out / f"seed-{seed}" / "summary.json").read_text())["steps"] == 200
    assert main(["slab", "--resume", str(out)]) == 0        # nothing left to run


def test_an_ensemble_resume_refuses_options_and_a_broken_record_in_one_line(tmp_path, capsys):
    ens = tmp_path / "ens"
    ens.mkdir()
    (ens / "ensemble.json").write_text("{not json")
    for extra, message in ((["--steps", "10"], "give no --steps with it"),
                           ([], "ensemble.json: unreadable")):
        assert main(["slab", "--resume", str(ens), *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1


# --- the bad-input sweep: every numeric option, NaN, inf, 0, negative, huge ----------------
SWEPT = ("nan", "inf", "-inf", "0", "-1", "1e300")


def numeric_options():
    """(command, option, its argparse type, how many values) of every option that takes
    numbers."""
    from cli.main import build_parser
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for command, p in sub.choices.items():
        for a in p._actions:
            if a.option_strings and a.type is not None and a.choices is None and \
                    getattr(a.type, "__name__", "") not in ("_literal",):
                yield command, a.option_strings[-1], a.type, a.nargs


@pytest.mark.parametrize("command, flag, kind, nargs", list(numeric_options()),
                         ids=lambda x: x if isinstance(x, str) else "")
def test_every_numeric_option_has_a_range_and_refuses_what_is_outside(tmp_path, capsys,
                                                                      command, flag, kind, nargs):
    """Parsed by a range of its own (no plain int or float): what lies outside gets one line,
    exit 2, before anything is made."""
    import argparse
    if kind in (int, float):
        pytest.fail(f"{command} {flag}: a plain {kind.__name__}, no range")
    for word in SWEPT:
        try:
            kind(word)
            continue                            # inside the range
        except argparse.ArgumentTypeError:
            pass
        if isinstance(nargs, int):              # LENGTH WIDTH THICKNESS: the last one bad
            if word == "-inf":
                continue                        # argparse takes it for an option
            given = [flag, *["1"] * (nargs - 1), word]
        else:
            given = [f"{flag}={word}"]
        code = main([command, *given, "--out", str(tmp_path / "x")])
        assert flag in one_line_error(capsys, code)
        assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("command, spec", [("slab", "cases.slab.SlabSpec"),
                                           ("wave1d", "cases.wave1d.Wave1DSpec")])
def test_every_numeric_key_of_a_case_refuses_what_is_outside_its_range(tmp_path, capsys,
                                                                       command, spec):
    """The options made from a case's fields: a value outside the field's range gets one line
    naming the field, exit 2, before anything is built."""
    import importlib
    from cli.commands._options import keyed_fields, option
    from orchestrator.casefile import integer, number
    module, name = spec.rsplit(".", 1)
    cls = getattr(importlib.import_module(module), name)
    model = ["--model", "coupled"] if command == "slab" else []
    checked = 0
    for f in keyed_fields(cls):
        kind, check = f.metadata["kind"], f.metadata["check"]
        if kind not in (number, integer) and "auto" not in str(f.default):
            continue
        for word in SWEPT:
            value = float(word)
            if kind is integer and math.isfinite(value) and value == int(value):
                value = int(value)
            if number(value)[1] is None and (kind is not integer or isinstance(value, int)) \
                    and (check is None or check(value) is None):
                continue                        # inside the range
            code = main([command, *model, f"{option(f.name)}={word}", "--out",
                         str(tmp_path / "x")])
            assert f.name in one_line_error(capsys, code), (f.name, word)
            assert not (tmp_path / "x").exists()
            checked += 1
    assert checked >= 4 * len(SWEPT)      # the loop saw the fields


# --- refused or warned instead of accepted silently ----------------------------------------
@pytest.mark.parametrize("setting, message", [
    ("coupling.layers=50", "coupling.layers = 50: the bridging band is 5 m wide (50 × element "
                           "size 0.1 m) and reaches x = -4.8 m, beyond the mesh's edge x = 0 m"),
    ("coupling.layers=3", "coupling.layers: at most 2 layers of 0.1 m fit"),
    ("time.steps=100000000000000", "time.steps = 100000000000000: must be in [1, 1e+09]"),
    ("time.dt=1e-300", "time.dt = 1e-300 s: below 0.001 × the smaller critical step"),
])
def test_impossible_keys_are_refused(tmp_path, capsys, setting, message):
    code = main(["run", str(small_case(tmp_path)), "--set", setting, "--out",
                 str(tmp_path / "out"), "--quiet"])
    assert message in one_line_error(capsys, code)


def test_a_band_with_no_spheres_in_its_outer_part_is_refused(tmp_path):
    script = SPHERES.replace("(0.1, 0.1, 0), (0.5, 0.5, 0.1)", "(0.15, 0.15, 0), (0.45, 0.45, 0.1)")
    with pytest.raises(CaseError, match=r"the spheres reach x = 0\.15\d* m, 0\.05\d* m short of "
                                        r"the bridging band's outer face x = 0\.1 m"):
        CaseModel(load(small_case(tmp_path, script_text=script)))


def test_an_element_size_that_is_not_the_meshs_is_refused_or_warned(tmp_path):
    """The box's own element size is 0.1 m; the first layer's thickness is measured."""
    case = small_case(tmp_path)
    with pytest.raises(CaseError, match=re.escape(
            "coupling.element_size = 0.04 m is 0.4 × the mesh's element size at the DE zone "
            "(0.1 m")) as refused:
        CaseModel(load(case, ["coupling.element_size=0.04"]))
    assert "within a factor 2" in str(refused.value)
    m = CaseModel(load(case, ["coupling.element_size=0.07"]))
    assert any("coupling.element_size = 0.07 m is 0.7 × the mesh's element size" in w
               for w in m.warnings)
    assert any(n.startswith("warning: coupling.element_size") for n in m.notes)


def test_a_gmsh_mesh_with_a_tenfold_element_size_is_refused(tmp_path):
    from test_run_case import write_plate_msh
    case = write_plate_msh(tmp_path)
    with pytest.raises(CaseError, match=re.escape(
            "coupling.element_size = 0.6 m is 10 × the mesh's element size at the DE zone "
            "(0.06 m")):
        CaseModel(load(case, ["coupling.element_size=0.6"]))


@pytest.mark.parametrize("sensor, message", [
    ('point = [50.0, -40.0, 9.0]', r"on FE node \d+, 64\.\d m from the point, farther than "
                                   r"0\.1 m"),
    ('point = [0.3, 0.3, 0.35]\non = "de"', r"on sphere \d+, 0\.2\d+ m from the point, "
                                             r"farther than 0\.1 m \(the element size\)"),
])
def test_a_sensor_far_from_the_model_is_refused_with_the_distance(tmp_path, sensor, message):
    case = small_case(tmp_path, extra=f'[[sensors]]\nname = "far"\n{sensor}\n')
    with pytest.raises(CaseError, match=r"sensors\[0\] \('far'\) at .*: " + message):
        CaseModel(load(case))


def test_every_sensor_says_what_it_is_on_and_how_far(tmp_path):
    extra = ('[[sensors]]\nname = "band"\npoint = [0.45, 0.3, 0.05]\n'
             '[[sensors]]\nname = "node"\npoint = [0.45, 0.3, 0.05]\non = "fe"\n')
    m = CaseModel(load(small_case(tmp_path, extra=extra)))
    band, node = [n for n in m.notes if n.startswith("sensors[")]
    assert re.search(r"'band'.*on sphere \d+ \(on = 'auto' in the bridging domain; on = 'fe' "
                     r"for the FE node\), 0\.0\d+ m from the point", band)
    # nodes at 0.4 and 0.5: the nearest is 0.05 m away in x, 0.05 in z
    assert re.search(r"'node'.*on FE node \d+, 0\.0707 m from the point", node)


@pytest.mark.parametrize("duration, message", [
    (1e-9, "time.duration = 1e-09 s is shorter than one time step"),
    (1e9, "time.duration = 1e+09 s needs"),
])
def test_a_duration_below_one_step_or_beyond_the_step_bound_is_refused(tmp_path, duration,
                                                                        message):
    case = small_case(tmp_path)
    case.write_text(case.read_text().replace("steps = 30", f"duration = {duration}"))
    with pytest.raises(CaseError, match=re.escape(message)):
        CaseModel(load(case))


# --- compare --------------------------------------------------------------------------------
def fake_slab_run(folder, model, peak, kind="slab"):
    """The files `compare` reads, of a run whose sensors moved by at most `peak`."""
    folder.mkdir()
    t = np.linspace(0, 1e-4, 11)
    history = peak * np.sin(np.linspace(0, 3, 11))[:, None, None] * np.ones((1, 2, 3))
    from orchestrator.run.outputs import write_sensors
    write_sensors(folder / "sensors.csv", ["under_impact", "far"], t, history)
    n = 4
    save_npz(folder / "damage.npz", times=t[[0, -1]], damage=np.zeros((2, n)),
             positions=np.zeros((n, 3)), radius=np.full(n, 0.025), in_de_zone=np.ones(n, bool),
             slab_index=np.arange(n))
    summary = {"case": "slab", "kind": kind, "n_spheres": n, "s_per_step": 0.01,
               "damage": {"broken_links": 0, "damaged_volume_m3": 0.0}}
    if kind == "slab":
        summary.update(model=model, spec={"radius": 0.025})
    write_json(folder / "summary.json", summary)
    return folder


def test_compare_of_runs_whose_sensors_did_not_move(tmp_path, capsys):
    full = fake_slab_run(tmp_path / "full", "full", 0.0)
    coupled = fake_slab_run(tmp_path / "coupled", "coupled", 0.0)
    assert main(["compare", str(full), str(coupled), "--out", str(tmp_path / "cmp")]) == 0
    out = capsys.readouterr().out
    assert "under_impact   peak ratio n/a  nRMS n/a" in out
    r = json.loads((tmp_path / "cmp" / "comparison.json").read_text())
    assert r["sensors"]["far"]["peak_ratio"] is None


@pytest.mark.parametrize("swap, kind, message", [
    (False, "generic", "holds a run of case 'slab' (generic), not a slab run"),
    (True, "slab", "holds a 'coupled' slab run, expected 'full'"),
])
def test_compare_refuses_what_is_not_a_full_and_a_coupled_slab_run(tmp_path, capsys, swap, kind,
                                                                     message):
    full = fake_slab_run(tmp_path / "full", "full", 1e-3, kind)
    coupled = fake_slab_run(tmp_path / "coupled", "coupled", 1e-3, kind)
    dirs = [coupled, full] if swap else [full, coupled]
    code = main(["compare", *map(str, dirs), "--out", str(tmp_path / "cmp")])
    assert message in one_line_error(capsys, code)
    assert not (tmp_path / "cmp").exists()


def test_compare_never_replaces_one_of_its_inputs(tmp_path, capsys):
    full = fake_slab_run(tmp_path / "full", "full", 1e-3)
    coupled = fake_slab_run(tmp_path / "coupled", "coupled", 1e-3)
    (full / MARKER).write_text("")
    code = main(["compare", str(full), str(coupled), "--out", str(full), "--force"])
    assert "an input of this run" in one_line_error(capsys, code)
    assert (full / "summary.json").is_file()


# --- the shipped block case -----------------------------------------------------------------
@pytest.mark.slow
def test_the_shipped_block_case_stays_stable_through_its_impact(tmp_path):
    """1.6 ms, links breaking from ~0.2 ms: with the consistent weighting the total energy is
    the model's own (no overlap counted twice) and nothing feeds it, so it may only fall (by
    damage), up to the leap-frog's O((ω dt)²) ~ 1 % oscillation at 0.15 × PWave. At the
    script's former 0.5 × PWave it passed twice the impact energy by step 450."""
    out = tmp_path / "block"
    assert main(["run", str(BLOCK), "--set", "time.duration=1.6e-3", "--out", str(out),
                 "--quiet"]) == 0
    s = json.loads((out / "summary.json").read_text())
    energy = np.array([e for _, e in s["energy"]])
    assert s["weighting"] == "consistent" and s["damage"]["broken_links"] > 0
    assert energy.max() <= 1.01 * s["reference_energy_J"]
    assert energy[-1] < s["reference_energy_J"]


def test_a_slab_case_file_names_its_model(tmp_path):
    """As `slab --model`: no default, full or coupled is the user's choice."""
    case = tmp_path / "slab.toml"
    case.write_text((ROOT / "cases" / "slab.toml").read_text().replace('model = "coupled"', ""))
    with pytest.raises(CaseError, match=re.escape("slab.model: missing (required)")):
        load(case)
