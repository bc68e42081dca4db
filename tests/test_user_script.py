"""Users' YADE scripts, unchanged: run for their set-up, made ready for coupling, refused
with a reason when they cannot be coupled."""
import textwrap
from pathlib import Path

import numpy as np
import pytest

from yade_side import import_yade
from yade_side.user_script import (ScriptRefused, body_table, insert_after_newton,
                                   prepare_dynamics, run_script)

yade = import_yade()
O = yade.Omega()
ROOT = Path(__file__).resolve().parents[1]
UNIAX = Path("/usr/share/doc/yade/examples/concrete/uniax.py")


def test_the_shipped_script_runs_unchanged_and_is_made_ready():
    scene = run_script(ROOT / "cases" / "scripts" / "block_impact.py")
    assert scene.run_requests == [((2000, True), {})]     # O.run neutralised: nothing ran
    assert O.iter == 1                                     # its own O.step() did run
    assert scene.dt_from_script == O.dt and O.dt > 0
    with pytest.warns(UserWarning, match="NewtonIntegrator damping was 0.2; set to 0"):
        newton = prepare_dynamics(scene)
    assert newton.damping == 0 and not O.dynDt
    bodies = body_table()
    assert not bodies["clump"].any() and bodies["dynamic"].all()
    impactor = int(scene.namespace["impactor"])
    assert bodies["radius"][bodies["ids"] == impactor] == 0.04
    # the script's PyRunner finds its function in __main__, as under YADE's launcher
    for _ in range(100):
        O.step()
    assert O.iter == 101


def test_the_coupling_step_runs_right_after_newton_once_per_step(tmp_path):
    script = tmp_path / "s.py"
    script.write_text(textwrap.dedent("""
        O.bodies.append([sphere((0, 0, 0), 0.01), sphere((0.1, 0, 0), 0.01)])
        O.bodies[1].state.vel = (1, 0, 0)
        seen = []
        O.engines = [ForceResetter(), NewtonIntegrator(damping=0),
                     PyRunner(command='seen.append(O.bodies[1].state.pos[0])', iterPeriod=1)]
        O.dt = 1e-3
    """))
    scene = run_script(script)
    assert scene.dt_from_script == 1e-3
    prepare_dynamics(scene)
    calls = []

    def couple():       # a correction of +1 mm in x, as the coupling writes it
        calls.append(O.iter)
        b = O.bodies[1].state
        b.pos = b.pos + yade.Vector3(1e-3, 0, 0)
    insert_after_newton(couple)
    names = [type(e).__name__ for e in O.engines]
    assert names == ["ForceResetter", "NewtonIntegrator", "PyRunner", "PyRunner"]
    for _ in range(3):
        O.step()
    assert calls == [0, 1, 2]
    # the script's own engine after Newton sees the corrected position, 0.1 + n (1 mm + 1 mm)
    # after step n (its PyRunner, without initRun, skips step 0)
    assert np.allclose(scene.namespace["seen"], [0.104, 0.106], rtol=0, atol=1e-15)


def test_a_periodic_cell_is_refused(tmp_path):
    script = tmp_path / "periodic.py"
    script.write_text("O.periodic = True\nO.cell.hSize = Matrix3(1,0,0, 0,1,0, 0,0,1)\n"
                      "O.engines = [NewtonIntegrator(damping=0)]\n")
    with pytest.raises(ScriptRefused, match="periodic cell"):
        prepare_dynamics(run_script(script))


def test_an_engine_list_without_newton_is_refused(tmp_path):
    script = tmp_path / "static.py"
    script.write_text("O.engines = [ForceResetter()]\n")
    with pytest.raises(ScriptRefused, match="0 NewtonIntegrator engines"):
        prepare_dynamics(run_script(script))


def test_missing_script_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.py"):
        run_script(tmp_path / "nope.py")


@pytest.mark.skipif(not UNIAX.is_file(), reason="YADE's examples are not installed")
def test_yades_own_uniax_example_builds_its_specimen_unchanged():
    """examples/concrete/uniax.py: its packing, material, engines and first step, as it runs
    them; its O.run() is left to the caller; then a few steps in this process."""
    scene = run_script(UNIAX)
    assert scene.run_requests, "uniax.py asked to run; nothing ran"
    assert O.iter == 1 and len(O.interactions) > 0   # its initTest() stepped once: links
    with pytest.warns(UserWarning, match="damping was 0.4"):
        prepare_dynamics(scene)
    bodies = body_table()
    assert len(bodies["ids"]) > 100 and np.all(bodies["radius"] == 3.5e-3)
    names = [type(e).__name__ for e in O.engines]
    assert "UniaxialStrainer" in names and "CpmStateUpdater" in names
    for _ in range(5):
        O.step()
    assert O.iter == 6
    vel = np.array([O.bodies[int(i)].state.vel for i in bodies["ids"]])
    assert np.isfinite(vel).all() and np.abs(vel).max() > 0   # the strainer moves its ends
