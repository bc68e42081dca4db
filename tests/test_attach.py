"""A YADE script run by YADE's own launcher (`yade script.py`) attaches the FE partner and the
coupling with one import and one call, and YADE's own loop (O.run) then drives both."""
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "cases" / "block_impact.toml"

SCRIPT = """
import json, sys
import numpy as np
exec(open(%(user)r).read().replace("O.run(2000, True)", ""))   # the user's script, unchanged
from cli.attach import attach
model = attach(%(case)r, ["coupling.variant='full'", "coupling.relaxation=1.0"])
model.bridge.set_velocity(np.random.default_rng(2).normal(size=(len(model.bridge), 3)))
O.run(20, True)
c = model.stepper.last
print(json.dumps({"steps": model.stepper.steps, "gap": float(np.abs(c.q - c.Gu).max()),
                  "scale": float(np.abs(c.q).max()), "engines": [type(e).__name__ for e in O.engines]}))
"""


def yade(tmp_path, script):
    path = tmp_path / "attached.py"
    path.write_text(script)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    return subprocess.run(["yade", "-x", "-n", str(path)], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=600)


def test_a_script_under_yades_launcher_couples_with_one_call(tmp_path):
    import json
    user = ROOT / "cases" / "scripts" / "block_impact.py"
    case = tmp_path / "plate.toml"
    text = CASE.read_text()
    case.write_text(text[:text.index("[de]")] + text[text.index("[material]"):]
                    .replace("duration = 4e-4", ""))
    r = yade(tmp_path, SCRIPT % {"user": str(user), "case": str(case)})
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["steps"] == 20                         # one coupling per YADE step
    engines = out["engines"]
    assert engines[engines.index("NewtonIntegrator") + 1] == "PyRunner"
    # full Lagrange, r = 1: the constraints hold to round-off of the positions (~1 m)
    assert out["scale"] > 1e-9 and out["gap"] < 64 * 2.2e-16


def test_attach_refuses_a_case_file_with_its_own_de_part(tmp_path):
    r = yade(tmp_path, f"from cli.attach import attach\nattach({str(CASE)!r})\n")
    assert r.returncode != 0
    assert "de.current = true: the YADE scene already built is the DE part" in r.stderr
