"""Fracture energy of CPM packings (yade_side.fracture) against CPM's link law integrated exactly."""
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from yade_side import import_yade
from yade_side.calibration import Loading
from yade_side.fracture import (break_strain_ratio, ductility_factor, ductility_for_factor,
                                balance_failure, link_work_density, mc2010_fracture_energy,
                                separation_test)
from yade_side.scene import BROKEN_OMEGA

from test_calibration import lattice

yade = import_yade()
REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("rel_ductility", [5.0, 30.0])
def test_break_strain_is_where_cpm_damage_reaches_the_threshold(rel_ductility):
    """x* solves ω(x* ε0) = omegaThreshold for YADE's own damage law (CpmPhys.funcG); g(r)
    matches the trapezoidal rule on σ/(E ε0²) = (1 − ω) x from YADE's funcG (error ≤
    x* h² max|f''| / 12 = x* h² / (12 r²) off the kink at x = 1, h the step); g inverts to r."""
    e0 = 1e-4
    x = break_strain_ratio(rel_ductility)
    funcG = yade.wrapper.CpmPhys.funcG
    assert funcG(x * e0, e0, rel_ductility * e0) == pytest.approx(BROKEN_OMEGA, abs=1e-13)
    xs = np.concatenate([np.linspace(0.0, 1.0, 3), np.linspace(1.0, x, 4001)[1:]])
    omega = np.array([funcG(xi * e0, e0, rel_ductility * e0) for xi in xs])
    h = (x - 1) / 4000
    g = ductility_factor(rel_ductility)
    assert np.trapz((1 - omega) * xs, xs) == pytest.approx(
        g, abs=x * h**2 / (12 * rel_ductility**2) + 1e-12)
    assert ductility_for_factor(g) == pytest.approx(rel_ductility, rel=1e-10)


@pytest.mark.parametrize("rel_ductility", [5.0, 30.0])
def test_lattice_dissipates_the_energy_of_its_links(rel_ductility):
    """Two planes of a simple cubic lattice (spacing d = 2.2 R: only the links along the axes)
    pulled apart: every x link is a chain of one link, strained exactly uniformly by the driven
    ends, and the link law integrated to its deletion gives Gf = π R² E ε0² g(r) / d per area d²
    of section. The transverse links stay unstrained (ν = 0). The work is integrated by the
    trapezoidal rule over steps of strain δ; its error is bounded by the force jump at deletion
    × δ (≤ E ε0 δ per link), relative δ/(ε0 g)."""
    R, d, E, e0 = 0.01, 2.2 * 0.01, 30e9, 1e-4
    mat = yade.wrapper.CpmMat(young=E, poisson=0.2, frictionAngle=0.5, sigmaT=3e6,
                              epsCrackOnset=e0, relDuctility=rel_ductility, density=4000)
    rate = 0.2
    run = separation_test(lattice((2, 3, 3), R, d), None,
                          Loading(strain_rate=rate, tension_rate=rate, sample_strain=1e-6),
                          material=mat, notch=0.0)
    exact = math.pi * R**2 * link_work_density(E, e0, rel_ductility) / d
    delta = rate * run["dt"]
    assert run["separated"]
    assert run["damping"] == 0 and run["elastic_end"] == 0
    assert run["fracture_energy"] == pytest.approx(
        exact, rel=delta / (e0 * ductility_factor(rel_ductility)))
    assert run["peak"] == pytest.approx(math.pi * R**2 * E * e0 / d**2, rel=delta / e0)


def test_a_balance_that_finds_more_energy_than_went_in_gives_no_fracture_energy():
    """The paper-scale plain set's separation test: the ends put in 55.6 J, damping alone took
    2,766 J (docs/calibration.md): the links' share would be negative, so no Gf."""
    assert balance_failure(55.6, 54.0) is None
    why = balance_failure(55.6, 0.91 + 30.6 + 2766.0)
    assert "2798 J" in why and "55.6 J" in why and "no fracture energy" in why
    assert balance_failure(55.6, 55.6) is not None     # the links dissipated nothing


def test_mc2010_fracture_energy():
    assert mc2010_fracture_energy(31e6) == pytest.approx(73 * 31**0.18, rel=1e-15)
    assert 134 < mc2010_fracture_energy(31e6) < 136
    with pytest.raises(ValueError, match="compressive strength"):
        mc2010_fracture_energy(0)
    with pytest.raises(ValueError, match="link energy factor"):
        ductility_for_factor(200.0)
    with pytest.raises(ValueError, match="link energy factor"):
        ductility_for_factor(0.5)


@pytest.mark.parametrize("args, message", [
    (["--gf", "-5"], "error: target fracture_energy must be a positive number (J/m²), got -5.0"),
    (["--gf-tol", "2"], "error: --gf-tol must be in (0, 1), got 2.0"),
    (["--gf", "100", "--no-gf"], "error: --gf 100.0 and --no-gf exclude each other"),
    (["--shear-contrib", "-1"], "error: concrete parameter equivStrainShearContrib must be a "
                                "non-negative number, got -1.0"),
    (["--dt-safety", "1.5"], "error: loading dt_safety must be <= 1 (× the critical step), got 1.5"),
    (["--shear-release=-1e-4"], "error: loading shear_release must be >= 0 s, got -0.0001"),
])
def test_cli_refuses_bad_fracture_options(tmp_path, args, message):
    r = subprocess.run([sys.executable, "-m", "cli", "calibrate", *args,
                        "--out", str(tmp_path / "c")], cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 2
    assert message in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "c").exists()
