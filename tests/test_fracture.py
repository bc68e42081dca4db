"""Fracture energy of CPM packings (yade_side.fracture) against CPM's link law integrated exactly,
and the links' dissipation measured on them (yade_side.dissipation) against a driver's work."""
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
    rel = delta / (e0 * ductility_factor(rel_ductility))
    assert run["fracture_energy"] == pytest.approx(exact, rel=rel)
    assert run["peak"] == pytest.approx(math.pi * R**2 * E * e0 / d**2, rel=delta / e0)
    # the links' own measure: every x link deleted, nothing sheared, the balance closed to the
    # ends' work over the step at deletion
    links = run["links"]
    assert links["deleted_count"] == 9 and links["shear"] == 0 and links["plastic"] == 0
    assert abs(run["closure"]) <= rel
    assert links["total"] == pytest.approx(run["work"], rel=rel)


def test_a_balance_that_does_not_close_gives_no_fracture_energy():
    """The paper-scale plain set's separation test at 0.8 x the critical step: the ends put in
    55.6 J, damping alone took 2,766 J (docs/calibration.md): energy was made inside, no Gf.
    A balance within CLOSURE of what went in closes; one that finds too little does not."""
    assert balance_failure(55.6, 54.0) is None and balance_failure(55.6, 57.0) is None
    why = balance_failure(55.6, 0.91 + 30.6 + 2766.0)
    assert "2798 J" in why and "55.6 J" in why and "no fracture energy" in why
    assert "made inside" in why
    short = balance_failure(55.6, 50.0)
    assert "-10.1 %" in short and "made inside" not in short


def held_spheres(centres, R=0.01):
    """A scene of CPM spheres of radius R at `centres`, every one held (moved only by the
    velocity given it), linked where they touch, at Δt = 1e-7 s."""
    from yade import utils
    from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene
    reset_scene()
    O = yade.Omega()
    mat = yade.wrapper.CpmMat(young=30e9, poisson=0.2, frictionAngle=0.5, sigmaT=3e6,
                              epsCrackOnset=1e-4, relDuctility=5.0, density=4000)
    O.materials.append(mat)
    ids = [O.bodies.append(utils.sphere(c, R, material=mat, fixed=True)) for c in centres]
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    return ids


def drive(body_id, meter, going):
    """Step while going(): the meter lists and samples after each step. Returns where the
    driven body was at each step's start (x), the force the driver applied there (f: minus
    the interactions' force on the body) and the driver's work (trapezoidal rule)."""
    O = yade.Omega()
    positions, forces = [np.array(O.bodies[body_id].state.pos)], []
    while going():
        O.step()
        meter.relist()
        meter.sample()
        positions.append(np.array(O.bodies[body_id].state.pos))
        forces.append(-np.array(O.forces.f(body_id)))
    x, f = np.array(positions[:-1]), np.array(forces)
    return x, f, float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x, axis=0)))


def test_link_meter_balances_the_work_on_one_link_pulled_obliquely_to_deletion():
    """Two linked spheres, one held, the other driven at a constant velocity at 45° to the
    link: tension damages the link (ω grows), the shear it carries slips as the cohesion
    (1 − ω) c falls, and the link is deleted past omegaThreshold. The driver's work (the
    trapezoidal rule on its force, step by step) equals the links' elastic energy plus what the
    meter finds dissipated: the two integrate the same states, the meter by parts (damage,
    slip, the deleted link's stored energy), to the trapezoid's second order (~1/N², N the
    steps) and the driver's last step, whose force YADE drops at deletion: (1 − ω) E κ A
    times the step's travel."""
    from yade_side.dissipation import LinkMeter
    from yade_side.scene import cpm_law
    R, e0 = 0.01, 1e-4
    _, driven = held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    O = yade.Omega()
    meter = LinkMeter()
    steps, stretch = 4000, 20 * e0          # along the link: 20 ε0 (past deletion) in 4000 steps
    speed = stretch * 2 * R / (steps * O.dt)
    O.bodies[driven].state.vel = (speed, speed, 0)
    x, f, work = drive(driven, meter, lambda: O.interactions.countReal() and O.iter < 20000)
    found = meter.dissipated()
    assert found["measured"] == found["deleted_count"] == 1 and found["plastic"] == 0
    assert found["damage"] > 0 and found["shear"] > 0 and found["deleted"] > 0
    assert cpm_law().elasticEnergy() == 0
    last = np.linalg.norm(x[-1] - x[-2]) * np.linalg.norm(f[-2])
    assert found["total"] == pytest.approx(work, abs=last + work / len(f) ** 2)


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
    (["--gf=-5"], "argument --gf: must be a finite number in (0, 1e+06], got '-5'"),
    (["--gf-tol", "2"], "argument --gf-tol: must be a finite number in (0, 1), got '2'"),
    (["--gf", "100", "--no-gf"], "error: --gf 100.0 and --no-gf exclude each other"),
    (["--shear-contrib=-1"], "argument --shear-contrib: must be a finite number in [0, 1], "
                             "got '-1'"),
    (["--dt-safety", "1.5"], "argument --dt-safety: must be a finite number in [0.001, 1], "
                             "got '1.5'"),
    (["--shear-release=-1e-4"], "argument --shear-release: must be a finite number in [0, 1], "
                                "got '-1e-4'"),
])
def test_cli_refuses_bad_fracture_options(tmp_path, args, message):
    r = subprocess.run([sys.executable, "-m", "cli", "calibrate", *args,
                        "--out", str(tmp_path / "c")], cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 2
    assert message in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "c").exists()


def test_link_meter_finds_a_contact_made_later_and_its_friction():
    """Two spheres, no link between them (beyond the link radius at the first step, then
    brought to 1e-4 R apart); one held, the other driven towards and along the first: the
    contact that forms is frictional (ω = 1: no cohesion, Coulomb's friction σN tan φ), the
    meter finds it when it lists the scene again, and the driver's work equals the contact's
    elastic energy plus what the meter finds dissipated (friction only), to: the trapezoid's
    second order; the step the contact forms in, whose travel its force acts on only in part
    (that step's force times its travel); and the law's own defect, which turns the shear
    strain with the contact but not its plastic part (yade_side/scene.py), so that the shear
    stress leans out of the contact plane by up to the contact's rotation, slip / L0, and that
    lean works on the normal travel (the shear force times the rotation times the travel)."""
    from yade_side.dissipation import LinkMeter
    from yade_side.scene import cpm_law
    R = 0.01
    # a held pair 4 R apart (no link) and a linked pair to start the meter with
    _, driven, _, _ = held_spheres([(0, 0, 0), (0, 0, 4 * R), (10 * R, 0, 0), (12 * R, 0, 0)], R)
    O = yade.Omega()
    O.bodies[driven].state.pos = (0, 0, 2.0001 * R)
    meter = LinkMeter()
    assert meter.dissipated()["measured"] == 1
    steps = 4000                      # 1e-4 R of approach, then 1e-3 of strain; 1e-2 R of slip
    O.bodies[driven].state.vel = (1e-2 * R / (steps * O.dt), 0,
                                  -(1e-4 + 2e-3) * R / (steps * O.dt))
    x, f, work = drive(driven, meter, lambda: O.iter < steps + 1)
    found = meter.dissipated()
    assert found["measured"] == 2 and found["deleted_count"] == 0
    assert found["damage"] == 0 and found["deleted"] == 0 and found["shear"] > 0
    first = np.flatnonzero(np.linalg.norm(f, axis=1))[0]
    formed = np.linalg.norm(x[first] - x[first - 1]) * np.linalg.norm(f[first])
    travel = np.abs(x[-1] - x[first])
    lean = np.abs(f[:, 0]).max() * travel[0] / (2 * R) * travel[2]
    assert found["total"] + cpm_law().elasticEnergy() == pytest.approx(
        work, abs=formed + work / len(f) ** 2 + lean)


def test_link_meter_sees_a_broken_pair_touch_again():
    """A link pulled apart to deletion, then its spheres pressed together again and slid: YADE
    gives the pair's interaction a new, frictional CpmPhys. The meter counts the link deleted
    (with the energy it took) and measures the new contact as another one; the driver's work
    over both legs equals the contact's elastic energy plus what the meter found dissipated,
    to the bounds of the two tests above (the step of deletion, the step the contact forms in,
    the lean of the shear stress, the trapezoid's second order)."""
    from yade_side.dissipation import LinkMeter
    from yade_side.scene import cpm_law
    R, e0 = 0.01, 1e-4
    _, driven = held_spheres([(0, 0, 0), (2 * R, 0, 0)], R)
    O = yade.Omega()
    meter = LinkMeter()
    steps = 2000
    O.bodies[driven].state.vel = (20 * e0 * 2 * R / (steps * O.dt), 0, 0)
    x1, f1, work1 = drive(driven, meter, lambda: O.interactions.countReal())
    gap = O.bodies[driven].state.pos[0] - 2 * R
    start = O.iter                    # back by the gap and 1e-3 of strain, 5e-2 R along y
    O.bodies[driven].state.vel = (-(gap + 2e-3 * R) / (steps * O.dt), 5e-2 * R / (steps * O.dt), 0)
    x2, f2, work2 = drive(driven, meter, lambda: O.iter < start + steps)
    found = meter.dissipated()
    assert found["measured"] == 2 and found["deleted_count"] == 1
    assert found["damage"] > 0 and found["deleted"] > 0 and found["shear"] > 0
    deletion = np.linalg.norm(x1[-1] - x1[-2]) * np.linalg.norm(f1[-2])
    first = np.flatnonzero(np.linalg.norm(f2, axis=1))[0]
    formed = np.linalg.norm(x2[first] - x2[first - 1]) * np.linalg.norm(f2[first])
    travel = np.abs(x2[-1] - x2[first])
    lean = np.abs(f2[:, 1]).max() * travel[1] / (2 * R) * travel[0]
    work = work1 + work2
    assert found["total"] + cpm_law().elasticEnergy() == pytest.approx(
        work, abs=deletion + formed + lean + work / min(len(f1), len(f2)) ** 2)
