"""The FE twin's figures (cases/slab/twin.py) against exact answers, and its bad input."""
import subprocess
import sys

import numpy as np
import pytest

from cases.slab.twin import TwinRun, judge


def test_a_twin_that_is_the_spheres_curve_scores_zero_and_the_exact_work():
    """The same curve on other samples: nRMS 0 to the peak (piecewise-linear, so exact at the
    spheres' samples), work ratio 1; a curve 10 % higher everywhere: nRMS 0.1 × the RMS of
    the spheres' stress to the peak over the peak, work 1.1."""
    e = np.linspace(0, 2e-3, 41)
    s = np.where(e < 1e-3, 3e10 * e, 3e7 * np.exp(-(e - 1e-3) / 5e-4))
    fine = np.linspace(0, 2.1e-3, 421)
    fe = TwinRun("tension", fine, np.interp(fine, e, s), 0.0, (2, 1, 1), 0.1)
    f = judge(e, s, fe, volume=2.0)
    assert f["nrms_to_peak"] == pytest.approx(0.0, abs=1e-12)
    assert f["work_ratio"] == pytest.approx(1.0, rel=1e-12)
    assert f["work_spheres_J"] == pytest.approx(2.0 * np.trapz(s, e), rel=1e-12)
    higher = TwinRun("compression", -fine, -1.1 * np.interp(fine, e, s), 0.0, (2, 1, 1), 0.1)
    f = judge(-e, -s, higher, volume=2.0)
    upto = s[:np.argmax(s) + 1]
    assert f["nrms_to_peak"] == pytest.approx(0.1 * np.sqrt(np.mean(upto ** 2)) / s.max(),
                                              rel=1e-9)
    assert f["work_ratio"] == pytest.approx(1.1, rel=1e-9)


@pytest.mark.parametrize("args, says", [
    (["--scale", "paper", "--concrete", "gf"], "no calibration record"),
    (["--radius", "0.02"], "--radius acts on the spheres' tests, not with --fe-twin"),
])
def test_a_twin_without_a_record_is_refused_in_one_line(tmp_path, args, says):
    run = subprocess.run([sys.executable, "-m", "cli", "calibrate", "--fe-twin", *args,
                          "--out", str(tmp_path / "twin")], capture_output=True, text=True)
    assert run.returncode == 2
    assert says in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert "Traceback" not in run.stderr


def test_a_cycle_is_matched_by_the_strain_travelled_and_judged_leg_by_leg():
    """A path out to 2e-4, back to −1e-4, out to 3e-4, σ = 20 GPa × ε: the FE's curve on other
    samples of the same path scores nRMS 0 and the legs' extremes exactly; 0.5 MPa higher
    everywhere, nRMS 0.5 MPa over the largest |σ|."""
    from cases.slab.twin import judge_cycle, travel
    targets = (2e-4, -1e-4, 3e-4)
    knots = np.array([0.0, *targets])
    path = lambda n: np.concatenate([np.linspace(knots[k], knots[k + 1], n)[k > 0:]
                                     for k in range(3)])
    e_s, e_f = path(11), path(101)
    s_s, s_f = 2e10 * e_s, 2e10 * e_f
    assert travel(e_s)[-1] == pytest.approx(2e-4 + 3e-4 + 4e-4, rel=1e-12)
    f = judge_cycle(e_s, s_s, TwinRun("cyclic", e_f, s_f, 0.0, (2, 1, 1), 0.1), targets)
    assert f["nrms_path"] == pytest.approx(0.0, abs=1e-12)
    assert [leg["spheres"] for leg in f["legs"]] == pytest.approx([4e6, -2e6, 6e6], rel=1e-12)
    assert [leg["fe"] for leg in f["legs"]] == pytest.approx([4e6, -2e6, 6e6], rel=1e-12)
    f = judge_cycle(e_s, s_s, TwinRun("cyclic", e_f, s_f + 5e5, 0.0, (2, 1, 1), 0.1), targets)
    assert f["nrms_path"] == pytest.approx(5e5 / 6e6, rel=1e-9)


def test_the_fe_bending_strip_starts_on_its_static_shape_and_does_not_ring():
    """Undamaged (strengths far above the stresses), the explicit FE strip whose nodes start on
    the elastic static deflection shape at the patch's speed stays on it: no acceleration, so
    the force is the static stiffness × the travel at every sample (to round-off); started at
    rest it would ring at its first mode."""
    from cases.slab import SlabSpec
    from cases.slab.bending import bending_to_failure_fe
    from fenicsx_side.damage_law import ConcreteDamage
    spec = SlabSpec(scale="small", fe_material="damage")
    law = ConcreteDamage(**dict(spec.damage_law(), tensile_strength=1e12,
                                compressive_strength=1e13))
    travel, force, dissipated, cells = bending_to_failure_fe(spec, law, 0.02, 2e-4, samples=20)
    stiffness = force[1:] / travel[1:]
    assert np.abs(stiffness / stiffness[0] - 1).max() < 1e-9
    assert dissipated == 0.0 and travel[-1] >= 2e-4
