"""Uniaxial tests of CPM packings (yade_side.calibration) against exact answers."""
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from yade_side import import_yade
from yade_side.calibration import Loading, Sample, packed_sample, summary, uniaxial_test
from yade_side.fit import Target, calibrate
from yade_side.material import ConcreteParams

yade = import_yade()
REPO = Path(__file__).resolve().parents[1]


def lattice(n, R, spacing, jitter=0.0, seed=0):
    """Spheres of radius R on a simple cubic lattice of n = (nx, ny, nz) sites `spacing` apart
    in the box [0, n × spacing], centres moved by up to jitter × R on each axis."""
    idx = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)
    centres = (idx + 0.5) * spacing
    centres += jitter * R * np.random.default_rng(seed).uniform(-1, 1, centres.shape)
    return Sample(centres, np.full(len(centres), R), tuple(float(k * spacing) for k in n))


def elastic_material(young=30e9, poisson=0.2):
    return yade.wrapper.CpmMat(young=young, poisson=poisson, frictionAngle=0.5, sigmaT=3e6,
                               epsCrackOnset=1e-4, relDuctility=30, density=4000,
                               neverDamage=True)


@pytest.mark.parametrize("mode", ["tension", "compression"])
def test_simple_cubic_lattice_has_the_modulus_of_its_links_and_no_lateral_strain(mode):
    """Links along the lattice axes only (spacing d = 2.2 R: the face diagonals √2 d are beyond
    the interaction radius 1.5 × 2R). A column of links of stiffness k carries σ = k ε d / d²,
    so E = k/d with CPM's k = E_c π R²/d (contact modulus × section / initial distance); no link
    is sheared, so ν = 0. The lattice stays uniformly strained (interior forces vanish), so the
    answer is exact at any rate, to round-off amplified by 1/ε ~ 1e5."""
    R, d = 0.01, 2.2 * 0.01
    E_c = 30e9
    run = uniaxial_test(lattice((10, 4, 4), R, d), None, mode,
                        Loading(strain_rate=1.0, tension_rate=1.0, max_strain=1e-4,
                                sample_strain=2e-6),
                        material=elastic_material(E_c))
    kn = {i.phys.kn for i in yade.Omega().interactions}
    assert np.allclose(list(kn), E_c * math.pi * R**2 / d, rtol=1e-14)
    exact = E_c * math.pi * R**2 / d**2
    assert run["E_ends"] == pytest.approx(exact, rel=1e-9)
    assert run["E"] == pytest.approx(exact, rel=1e-9)
    assert abs(run["nu"]) < 1e-9


def jittered_lattice():
    """An irregular packing made without compaction (cheap, deterministic): spheres of a
    simple cubic lattice at touching distance, moved randomly by up to 0.1 R; interaction radius
    1.5 links face diagonals too, ~18 links per inner sphere."""
    return lattice((8, 4, 4), 0.01, 0.02, jitter=0.1)


def test_elastic_modulus_does_not_depend_on_the_strain_rate():
    """Never-damaged links: E and ν at the default quasi-static rate (scaled to this specimen's
    length: the same number of wave transits) and at half of it agree to 0.5 %."""
    sample = jittered_lattice()
    rate = 0.05 * 0.56 / sample.size[0]
    runs = [uniaxial_test(sample, None, "compression",
                          Loading(strain_rate=r, max_strain=3e-4), material=elastic_material())
            for r in (rate, rate / 2)]
    assert runs[1]["E"] == pytest.approx(runs[0]["E"], rel=5e-3)
    assert runs[1]["nu"] == pytest.approx(runs[0]["nu"], abs=5e-3)


def test_cpm_law_is_homogeneous_in_young_sigmaT_and_density():
    """young, sigmaT and density × μ (epsCrackOnset, relDuctility fixed) make every link force
    μ times larger at the same displacements and every mass μ times larger: the motion is the
    same and every stress is μ times larger, through damage and softening, to round-off. Without
    damping: Cundall's damping force ∝ sign(v) would turn round-off into O(1) differences."""
    sample = jittered_lattice()
    loading = Loading(strain_rate=1.0, max_strain=2.5e-3, damping=0.0)
    base = ConcreteParams()
    mu = 2.5
    scaled = replace(base, young=mu * base.young, sigmaT=mu * base.sigmaT,
                     density=mu * base.density)
    a = uniaxial_test(sample, base, "compression", loading)
    b = uniaxial_test(sample, scaled, "compression", loading)
    assert a["steps"] == b["steps"] and a["dt"] == pytest.approx(b["dt"], rel=1e-15)
    assert np.argmax(-a["stress"]) < len(a["stress"]) - 1    # past the peak: through damage
    # round-off (1e-16) grows through damage and slip decisions: 1e-9 measured at the end
    scale = np.abs(a["strain_mid"]).max()
    assert np.allclose(b["strain_mid"], a["strain_mid"], rtol=0, atol=1e-7 * scale)
    assert np.allclose(b["stress"], mu * a["stress"], rtol=0, atol=1e-7 * mu * abs(a["peak"]))


def test_bad_input_is_refused_with_the_value():
    with pytest.raises(ValueError, match="strain_rate"):
        Loading(strain_rate=0)
    with pytest.raises(ValueError, match="stop_ratio"):
        Loading(stop_ratio=1.5)
    with pytest.raises(ValueError, match="poisson"):
        Target(poisson=0.3)
    with pytest.raises(ValueError, match="young"):
        Target(young=-1)
    with pytest.raises(ValueError, match="diameters"):
        packed_sample(0.05, (0.56, 0.56, 0.28))
    with pytest.raises(ValueError, match="mode"):
        uniaxial_test(jittered_lattice(), ConcreteParams(), "shear")


def test_cli_reports_bad_input_without_traceback(tmp_path):
    r = subprocess.run([sys.executable, "-m", "cli", "calibrate", "--radius", "-0.01",
                        "--out", str(tmp_path / "c")], cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 2
    assert "argument --radius: must be a finite number in (0, 0.1], got '-0.01'" in r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.slow
def test_strengths_scale_with_sigmaT_and_epsCrackOnset_at_fixed_young():
    """sigmaT and epsCrackOnset × λ: the link law becomes σ'(λε) = λσ(ε), so fc and ft × λ with E
    unchanged, up to the quasi-static error of the rate (~1 %, docs/calibration.md)."""
    sample = packed_sample(0.025, (0.56, 0.56, 0.28))
    base, lam = ConcreteParams(), 1.5
    scaled = replace(base, sigmaT=lam * base.sigmaT, epsCrackOnset=lam * base.epsCrackOnset)
    m = [summary(uniaxial_test(sample, p, "compression"), uniaxial_test(sample, p, "tension"))
         for p in (base, scaled)]
    assert m[1]["E"] == pytest.approx(m[0]["E"], rel=5e-3)
    assert m[1]["fc"] == pytest.approx(lam * m[0]["fc"], rel=0.03)
    assert m[1]["ft"] == pytest.approx(lam * m[0]["ft"], rel=0.03)


@pytest.mark.slow
def test_calibration_reaches_the_slab_concrete():
    """The fit on the small slab scale's specimen reaches E = 31 GPa, fc = 31 MPa within 5 %."""
    sample = packed_sample(0.025, (0.56, 0.56, 0.28))
    target = Target(young=31e9, compressive_strength=31e6)
    result = calibrate(sample, target, tol=0.02, log=lambda *_: None)
    m = summary(result["compression"], result["tension"])
    assert m["E"] == pytest.approx(31e9, rel=0.05)
    assert m["fc"] == pytest.approx(31e6, rel=0.05)
    assert len(result["iterations"]) <= 6


def test_a_cycle_turns_at_its_targets_and_an_elastic_lattice_follows_its_modulus_both_ways():
    """The simple cubic lattice of links along the axes (above: E = k/d exactly) driven out,
    back past zero and out again (yade_side.cyclic): every leg ends at its target, and the
    stress is E × strain at every sample, compression included; the lattice stays uniformly
    strained as each leg starts on its own linear velocity field."""
    from yade_side.cyclic import cyclic_test
    R, d, E_c = 0.01, 2.2 * 0.01, 30e9
    targets = (5e-5, -3e-5, 2e-5)
    run = cyclic_test(lattice((10, 4, 4), R, d), None, targets, 1.0,
                      Loading(sample_strain=2e-5), notch=0.0, material=elastic_material(E_c))
    exact = E_c * math.pi * R**2 / d**2
    e, s = run["strain"], run["stress"]
    turns = [np.argmax(e), np.argmin(e)]
    assert e[turns[0]] >= targets[0] and e[turns[1]] <= targets[1] and e[-1] >= targets[2]
    assert turns[0] < turns[1] and np.all(np.diff(e[turns[1]:]) > 0)
    assert np.abs(s - exact * e).max() <= 1e-9 * exact * np.abs(e).max()
