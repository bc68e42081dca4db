"""The slab case end to end at small scale, and its invariants."""
import json

import numpy as np
import pytest

from cases import slab
from cli.main import main

STEPS = 150  # contact starts after step ~30 at small scale (dt = 0.15 x PWave)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("slab")
    for model, extra in (("full", []), ("coupled", []),
                         ("coupled", ["--fe-material", "damage"])):
        folder = root / "-".join([model] + extra[1:])
        zone = ["--zone", "box"] if model == "coupled" else []   # a fixed zone's outputs
        assert main(["slab", "--model", model, "--scale", "small", "--steps", str(STEPS),
                     "--output-every", "150", "--out", str(folder), "--quiet", *zone,
                     *extra]) == 0
    for coupled, cmp in (("coupled", "cmp"), ("coupled-damage", "cmp-damage")):
        assert main(["compare", str(root / "full"), str(root / coupled),
                     "--out", str(root / cmp)]) == 0
    return root


def test_an_fe_that_damages_writes_its_damage_and_counts_it_in_the_damaged_volume(runs):
    """--fe-material damage: the FE's damage in fe.xdmf and damage.npz; the damaged volume is
    the spheres' and the FE cells' in one measure (a cell counts once broken as a link is),
    each weighted by its share of the band."""
    import h5py
    summary = json.loads((runs / "coupled-damage" / "summary.json").read_text())
    d = summary["damage"]
    assert d["damaged_volume_m3"] == pytest.approx(d["damaged_volume_de_m3"]
                                                   + d["damaged_volume_fe_m3"], rel=1e-12)
    fe = summary["fe_damage"]
    assert 0 <= fe["max"] <= 1 and fe["cells_damaged"] <= fe["cells"]
    with np.load(runs / "coupled-damage" / "damage.npz") as z:
        assert z["fe_damage"].max(initial=0.0) == fe["max"]
        assert z["fe_broken"] @ z["fe_volume"] == pytest.approx(d["damaged_volume_fe_m3"],
                                                                rel=1e-12, abs=1e-18)
        assert np.array_equal(z["fe_broken"], z["fe_damage"] >= 0.99)
        assert np.all((0 <= z["sphere_share"]) & (z["sphere_share"] <= 1))
    last = sorted((runs / "coupled-damage" / "fe").glob("step*.h5"))[-1]
    with h5py.File(last) as f:
        assert f["damage"].shape == (fe["cells"], 1)
    assert json.loads((runs / "coupled" / "summary.json").read_text())["fe_damage"] is None
    assert (runs / "cmp-damage" / "comparison.json").is_file()
    # the cracking energy: the FE's cells' sum is its total (no conversion), the links' and
    # cells' arrays sum to the slab's figure
    crack = summary["quantities"]["cracking_energy"]
    assert crack["slab_fe_J"] == pytest.approx(fe["dissipated_J"], rel=1e-12)
    with np.load(runs / "coupled-damage" / "damage.npz") as z:
        assert z["crack_energy"].sum() == pytest.approx(crack["slab_J"], rel=1e-12)
        assert z["crack_energy"][z["crack_fe"]].sum() == pytest.approx(crack["slab_fe_J"],
                                                                       rel=1e-12)
    assert crack["slab_links_J"] > 0 and crack["slab_fe_J"] > 0
    # the profile along the span at the centre's peak holds that peak, at its time
    q = summary["quantities"]
    profile = q["profile_at_peak"]
    assert profile["time_s"] == q["peaks"]["deflection_x1.25"]["time_s"]
    assert profile["deflection_m"][profile["x_m"].index(1.25)] == \
        q["peaks"]["deflection_x1.25"]["peak"]


def test_bad_damage_input_is_one_line(tmp_path, capsys):
    """A fracture energy or strength that is not positive, fc below ft, or cells too wide for
    the crack band: one line, exit 2, before anything is built."""
    for extra, words in ((["--fracture-energy", "0"], "fracture_energy must be"),
                         (["--fracture-energy", "-5"], "fracture_energy must be"),
                         (["--tensile-strength", "40e6"], "must exceed tensile_strength"),
                         (["--fracture-energy", "1"], "beyond the crack band's limit")):
        assert main(["slab", "--model", "coupled", "--fe-material", "damage", *extra,
                     "--out", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("args, words", [
    (["--model", "coupled", "--dt-safety", "1e-300"],
     "dt_safety must be in [0.001, 1] (× the critical step), got 1e-300"),
    (["--model", "full", "--zone", "grow"], "--zone grow finds the DE zone of a coupled model"),
    (["--model", "full", "--zone", "auto"], "--zone auto finds the DE zone of a coupled model"),
])
def test_bad_run_input_is_one_line(tmp_path, capsys, args, words):
    assert main(["slab", *args, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_both_models_run_and_compare_with_finite_values(runs):
    comparison = json.loads((runs / "cmp" / "comparison.json").read_text())
    for s in comparison["sensors"].values():
        assert np.isfinite(s["peak_full"]) and np.isfinite(s["peak_coupled"])
    assert np.isfinite(comparison["speedup_per_step"])
    for name in ("histories.png", "damage_maps.png"):
        assert (runs / "cmp" / name).stat().st_size > 0
    for model in ("full", "coupled"):
        summary = json.loads((runs / model / "summary.json").read_text())
        assert summary["steps"] == STEPS
        assert set(summary["time_split_s"]) == {"yade", "fe", "coupling", "output"}
        assert (runs / model / "spheres.pvd").is_file()
    assert (runs / "coupled" / "fe.xdmf").is_file()


def test_compare_gives_where_the_energy_went(runs):
    """Each run's energy split at its end (summary.json) and at each frame (damage.npz: t = 0,
    whose residual is round-off, and the last step; the time, the residual, the terms);
    compare's means, which for one member each are the members' own, and its page's table."""
    from cases.slab.energies import REGIONS, TERMS
    comparison = json.loads((runs / "cmp" / "comparison.json").read_text())
    split = comparison["energy_split"]
    for side, model in (("full", "full"), ("coupled", "coupled")):
        own = json.loads((runs / model / "summary.json").read_text())["quantities"]["energy_split"]
        assert split[side]["terms"] == own["terms"] and split[side]["input_J"] == own["input_J"]
        rows = np.load(runs / model / "damage.npz")["energy_rows"]
        assert rows.shape == (2, 2 + len(TERMS) * len(REGIONS))
        assert rows[-1, 1] == own["residual_J"] and abs(rows[0, 1]) <= 1e-12 * own["input_J"]
    assert split["members"] == {"full": 1, "coupled": 1}
    assert 'id="energy-split"' in (runs / "cmp" / "report.html").read_text()


def test_the_full_run_records_its_concrete_and_its_links_outside_the_de_zone(runs):
    """summary.json: the CPM set used; the record of every initial slab link (each counted
    once: the spheres' initial link counts add to twice as many) and the variants'
    measurement, which reads the same damaged volume as the run."""
    from dataclasses import asdict
    from cases.slab.variants import measure_folders
    summary = json.loads((runs / "full" / "summary.json").read_text())
    assert summary["cpm"] == asdict(slab.concrete(slab.SlabSpec(scale="small")))
    links = summary["links_outside_de_zone"]
    assert 2 * links["links_total"] == summary["damage"]["initial_links"]
    assert 0 < links["links"] < links["links_total"]
    assert links["broken_total"] <= links["damaged_total"] <= links["links_total"]
    row, = measure_folders([runs / "full"])
    assert row["damaged_volume_m3"] == pytest.approx(summary["damage"]["damaged_volume_m3"],
                                                     rel=1e-12, abs=1e-15)
    assert "links_outside_de_zone" not in json.loads((runs / "coupled" / "summary.json").read_text())


def test_a_results_folder_is_never_overwritten(runs, capsys):
    assert main(["slab", "--model", "full", "--out", str(runs / "full"), "--steps", "1"]) == 2
    assert "--force" in capsys.readouterr().err


def test_model_invariants():
    """Before contact the impactor flies rigidly (its internal forces cancel: momentum and
    velocity exact) and the slab is at rest; no cohesive link joins impactor and slab; the
    supports hold: supported spheres (full) and the FE support faces (coupled) keep u_z = 0."""
    from yade_side import import_yade
    O = import_yade().Omega()
    spec = slab.SlabSpec(scale="small", steps=200, dt_safety=0.3, impactor_gap=0.01)
    for model in ("full", "coupled"):
        m = slab.SlabModel(spec, model)
        impactor, slab_ids = set(m.impactor_ids.tolist()), set(m.slab_ids.tolist())
        links = [(i.id1, i.id2) for i in O.interactions if i.phys.isCohesive]
        assert not any((a in impactor) != (b in impactor) for a, b in links)
        p0 = m.impactor.mass @ m.impactor.read()[:, 3:6]
        first = m.quantities()
        free_flight = int(spec.impactor_gap / (spec.impactor_speed * m.dt))  # ~80 steps
        for _ in range(free_flight):
            m.step()
        check_energy_before_contact(m, first)
        m.impactor.read()
        assert np.allclose(m.impactor.mass @ m.impactor.vel, p0, rtol=0,
                           atol=1e-12 * np.linalg.norm(p0))
        assert np.allclose(m.impactor.vel, [0, 0, -spec.impactor_speed], rtol=0,
                           atol=1e-12 * spec.impactor_speed)
        assert not m.slab.read()[:, 3:6].any(), "slab at rest before contact"
        for _ in range(spec.steps - free_flight):
            m.step()
        m.slab.read()
        assert np.abs(m.slab.vel).max() > 0, "the impact happened"
        if model == "full":
            z = {int(i): O.bodies[int(i)].state.pos[2] - O.bodies[int(i)].state.refPos[2]
                 for i in m.support_ids}
            assert len(z) > 0 and not any(z.values())
        else:
            on_support = np.isclose(m.fe.nodes[:, 0], 0) | np.isclose(m.fe.nodes[:, 0], slab.SLAB[0])
            assert on_support.any() and not m.fe.u[3 * np.flatnonzero(on_support) + 2].any()
            assert len(slab_ids) < 9514  # a DE zone, not the whole slab
        check_quantities(m, O)


def check_energy_before_contact(m, q):
    """Before contact the energy split (cases.slab.energies) is the impactor's kinetic
    energy, which is the input, ½ M v²: nothing else moves, strains or dissipates (the
    impactor's links hold round-off only)."""
    q.sample()
    q.output()
    split = q.energy.split(q.cracking_map())
    total = q.energy.input
    assert total == pytest.approx(0.5 * m.impactor.mass.sum() * m.spec.impactor_speed ** 2,
                                  rel=1e-12)
    assert split["kinetic"]["impactor"] == pytest.approx(total, rel=1e-12)
    assert abs(split["residual"]) <= 1e-12 * total


def check_energy_split(m, q):
    """The split's places partition the model's own totals: its kinetic energy (spheres and
    FE), the FE's strain energy, the cracking QoI's totals, the links' stored energy; the
    coupling's term is its exchange meter's; the residual is the input less the sum."""
    from cases.slab.energies import REGIONS
    q.output()
    split = q.energy.split(q.cracking_map())
    total = lambda term: sum(split[term][r] for r in REGIONS)       # noqa: E731
    kinetic = sum(b.kinetic_energy() for b in m.energy_bodies)
    elastic = q.energy.meter.stored(q.energy.meter.alive()).sum()
    if m.fe is not None:
        kinetic += m.fe.kinetic_energy()
        elastic += m.fe.strain_energy()
        assert split["coupling"]["band"] == -m.stepper.exchange.net
    assert total("kinetic") == pytest.approx(kinetic, rel=1e-12) and kinetic > 0
    assert total("elastic") == pytest.approx(elastic, rel=1e-12) and elastic > 0
    cracking = q.cracking_map()[0]
    assert total("cracking") == pytest.approx(cracking["slab_J"] + cracking["impactor_J"],
                                              rel=1e-12)
    assert split["residual"] == pytest.approx(
        q.energy.input - sum(total(t) for t in split if t != "residual"), rel=1e-12)
    assert split["kinetic"]["zone"] > 0 and split["kinetic"]["impactor"] > 0


def check_quantities(m, O, steps=5):
    """The QoIs against what they are measured by (cases.slab.quantities), over `steps`
    steps past contact: the contact force is the mean over the steps of the sum of YADE's
    forces on the impactor's spheres; the reaction is what holds the supports: minus YADE's
    z forces on the supported spheres (full; every force inside the packing cancels), or
    the FE's internal force K u at its held dofs (coupled, elastic FE: the coupling's forces
    cancel, Σ_a N_a = 1); the patch means of a uniform z displacement added to every sphere
    and FE node are that displacement. Tolerances: the round-off of the momentum sums,
    divided by the interval."""
    eps = np.finfo(float).eps
    q = m.quantities()
    force = held = 0.0
    z_held = None if m.fe is None else np.flatnonzero(m.fe.fixed & (np.arange(m.fe.ndof) % 3 == 2))
    for _ in range(steps):
        u = None if m.fe is None else m.fe.u.copy()
        m.step()
        force += sum(O.forces.f(int(i))[2] for i in m.impactor_ids) / steps
        held += (-sum(O.forces.f(int(i))[2] for i in m.support_ids) if m.fe is None
                 else (m.fe.K @ u)[z_held].sum()) / steps
    values = dict(zip(q.names, q.sample()))
    check_energy_split(m, q)
    size = sum(np.abs(b.mass * b.read()[:, 5]).sum() for b in m.energy_bodies)
    if m.fe is not None:
        size += np.abs(m.fe.mass * m.fe.v).sum()
    tol = 16 * eps * size / (steps * m.dt)          # N: a few ulps of each momentum term
    assert abs(force) > 1e3 * tol and values["contact_force"] == pytest.approx(force, abs=tol)
    assert abs(held) > 1e3 * tol and values["reaction"] == pytest.approx(held, abs=tol)
    before = q.sample()[5:]
    m.spheres.move(np.array([0.0, 0.0, -1e-3]))
    expected = np.full(len(before), -1e-3)
    if m.fe is not None:
        shift = np.where(~m.fe.fixed & (np.arange(m.fe.ndof) % 3 == 2), -1e-3, 0.0)
        m.fe.u = m.fe.u + shift
        # a patch whose points lie in a cell at a support reads its held nodes, which stay
        held = np.asarray(q.fe_mean[:, m.fe.fixed].sum(axis=1)).ravel()
        assert set(np.flatnonzero(held)) <= {0, 8}              # x = 0.25 and 2.25 only
        expected *= 1 - held
    np.testing.assert_allclose(q.sample()[5:] - before, expected, rtol=0, atol=8 * eps)


def test_patches_are_the_bottom_spheres_within_the_radius():
    """A sphere's centre on the centre line, just inside a patch's rim or just past it, in the
    bottom layer or one diameter up: only those within PATCH_RADIUS and one diameter of
    z = 0."""
    from cases.slab.quantities import PATCH_RADIUS, PROFILE_Y, patch_points
    r = 0.01
    x = 1.25
    centres = np.array([[x, PROFILE_Y, r], [x + PATCH_RADIUS * (1 - 1e-9), PROFILE_Y, r],
                        [x, PROFILE_Y + PATCH_RADIUS * (1 + 1e-9), r], [x, PROFILE_Y, 2.01 * r],
                        [x - 0.6 * PATCH_RADIUS, PROFILE_Y + 0.6 * PATCH_RADIUS, 1.99 * r]])
    centres = np.vstack([centres, [[xp, PROFILE_Y, r] for xp in (0.25, 0.5, 0.75, 1.0, 1.5,
                                                                  1.75, 2.0, 2.25)]])
    patches = patch_points(centres, r)
    assert patches[x].tolist() == [0, 1, 4] and len(patches) == 9
    with pytest.raises(ValueError, match="no sphere of the packing in the patch at x = 0.25 m"):
        patch_points(centres[:5], r)


def test_support_line_is_the_mean_distance_of_the_held_centres_from_their_face():
    """Held: centres within two radii of x = 0 or x = 2.5 (0.03, 0.04 and 2.47 m here, not
    0.06 or 1.0 m): 0.03, 0.04 and 0.03 m from their face."""
    from cases.slab.packings import support_line, supported
    c = np.zeros((5, 3))
    c[:, 0] = [0.03, 0.04, 2.47, 0.06, 1.0]
    r = np.full(5, 0.025)
    assert supported(c, r).tolist() == [True, True, True, False, False]
    assert support_line(c, r) == pytest.approx(0.1 / 3, rel=1e-14)


def test_grid_rejects_a_de_zone_that_does_not_fit():
    with pytest.raises(ValueError, match="do not fit"):
        slab.slab_grid(slab.SlabSpec(scale="small", de_zone=1.8))


def test_impactor_starts_beyond_the_link_reach_and_then_just_above_the_slab():
    """When the links are made, the closest impactor-slab pair sits 1.05 × the link reach apart
    (1.5 × the sum of radii; all radii equal here); lowered by impactor_drop, the impactor
    falls exactly impactor_gap before its first sphere touches the slab."""
    from scipy.spatial import cKDTree
    from yade_side.scene import INTERACTION_RADIUS
    spec = slab.SlabSpec(scale="small")
    p = slab.make_packings(spec)
    d = 2 * p.slab_radii[0]
    assert np.ptp(np.concatenate([p.slab_radii, p.impactor_radii])) == 0
    gap = cKDTree(p.slab_centres).query(p.impactor_centres)[0].min()
    assert np.isclose(gap / d, 1.05 * INTERACTION_RADIUS, rtol=1e-12)
    start = p.impactor_centres - [0, 0, p.impactor_drop]
    pairs = cKDTree(start[:, :2]).query_ball_tree(cKDTree(p.slab_centres[:, :2]), d)
    fall = min(start[i, 2] - p.slab_centres[j, 2]
               - np.sqrt(d**2 - np.sum((start[i, :2] - p.slab_centres[j, :2]) ** 2))
               for i, near in enumerate(pairs) for j in near if start[i, 2] > p.slab_centres[j, 2])
    assert np.isclose(fall, spec.impactor_gap, rtol=0, atol=1e-12)


def test_full_width_de_zone_is_bounded_along_x_only():
    grid = slab.slab_grid(slab.SlabSpec(scale="small", full_width=True))
    assert grid.axes == (0,)
    assert grid.hole_lo[1] == 0 and grid.hole_hi[1] == slab.SLAB[1]
    boxed = slab.slab_grid(slab.SlabSpec(scale="small"))
    assert boxed.axes == (0, 1) and 0 < boxed.hole_lo[1] < boxed.hole_hi[1] < slab.SLAB[1]


def test_consistent_weighting_puts_alpha_and_beta_inside_both_models():
    """Small scale, DE strip through the width: the FE's lumped mass is ρ ∫ α over the FE
    domain with α interpolated at the nodes: V_FE − (one band's volume / 2) per side for the
    linear ramp, plus the 0.01 floor at the band's inner nodes (a hat of height 0.01 over the
    first element layer: 0.01 h/2 per unit area); every bridging sphere's YADE mass is β × its
    own (mass / (β r³) the same for all); the coupling then takes α = β = 1."""
    spec = slab.SlabSpec(scale="small", de_zone=0.6, full_width=True, layers=3,
                         weighting="consistent")
    m = slab.SlabModel(spec, "coupled")
    g = m.grid
    thickness, width = slab.SLAB[2], slab.SLAB[1]
    band = spec.layers * g.h * width * thickness
    v_fe = (slab.SLAB[0] - (g.hole_hi[0] - g.hole_lo[0])) * width * thickness
    floor = 2 * 0.01 * g.h / 2 * width * thickness
    assert m.fe.mass.sum() / 3 == pytest.approx(spec.density * (v_fe - band + floor), rel=1e-12)
    beta = m.bridging.beta(m.bridge.ref_pos)
    assert beta.min() < 0.05 and beta.max() > 0.95
    per_volume = m.bridge.mass / (beta * m.bridge.radius**3)
    assert np.ptp(per_volume) <= 1e-12 * per_volume.max()
    c = m.stepper.coupling
    assert np.allclose(c.de_inv_mass[:3 * c.n], np.repeat(1 / m.bridge.mass, 3), rtol=1e-14)
    with pytest.raises(ValueError, match="weighting must be"):
        slab.SlabSpec(weighting="paper")


def test_elastic_outside_keeps_exactly_the_links_outside_the_de_zone_undamageable():
    from yade_side import import_yade
    O = import_yade().Omega()
    spec = slab.SlabSpec(scale="small", elastic_outside=True)
    with pytest.raises(ValueError, match="full model only"):
        slab.SlabModel(spec, "coupled")
    m = slab.SlabModel(spec, "full")
    links = [i for i in O.interactions if i.isReal and i.phys.isCohesive]
    mid = np.array([0.5 * (np.array(O.bodies[i.id1].state.refPos)
                           + np.array(O.bodies[i.id2].state.refPos)) for i in links])
    outside = m.bridging.zone.depth(mid) > 0
    assert 0 < outside.sum() < len(links) and m.elastic_links == outside.sum()
    assert [i.phys.neverDamage for i in links] == outside.tolist()


def test_auto_relaxation_is_the_1d_rule_for_the_slab_grid():
    from orchestrator.coupling.relaxation import auto_relaxation
    spec = slab.SlabSpec(scale="small", relaxation="auto")
    ratio = slab.slab_grid(spec).h / (2 * spec.radius)
    assert spec.relaxation == auto_relaxation(ratio, spec.layers, spec.variant, spec.dt_safety)
    with pytest.raises(ValueError, match="relaxation"):
        slab.SlabSpec(scale="small", relaxation=0.0)


@pytest.mark.slow
def test_a_full_run_warns_when_links_outside_the_de_zone_crack(tmp_path):
    """By 0.85 ms (300 steps; 8,602 links measured) the impact's stress waves have cracked
    links where the coupled model has its band and FE (docs/slab.md): the full run says so,
    as the coupled one's FE check would."""
    assert main(["slab", "--model", "full", "--scale", "small", "--steps", "300",
                 "--output-every", "300", "--out", str(tmp_path / "full"), "--quiet"]) == 0
    warnings = json.loads((tmp_path / "full" / "summary.json").read_text())["warnings"]
    assert any("outside the coupled model's DE zone are damaged" in w for w in warnings)


def test_a_qoi_peaks_in_its_sense():
    """A rebounding impactor's centre rises past its start: its peak is the largest descent;
    the reaction's is its largest magnitude, a pull as well; unmeasured samples never."""
    from cases.slab.quantities import peak_index
    assert peak_index("impactor_z", [0.0, -5.0, -3.0, 8.0]) == 1
    assert peak_index("deflection_x1.25", [0.0, -1.0, 0.5, -0.9]) == 1
    assert peak_index("penetration", [-2.0, 3.0, 9.0, 8.0]) == 2
    assert peak_index("reaction", [np.nan, 5.0, -9.0, 4.0]) == 2
    assert peak_index("contact_force", [np.nan, 0.0, 7.0, -9.0]) == 2


def test_the_event_ends_when_the_impactor_stopped_and_the_slab_rebounded():
    """Synthetic QoIs: the impactor's velocity rises linearly from -10 m/s and passes -0.1 m/s
    (STOPPED × 10) at t = 0.99 ms; the centre sinks as -sin(πt/T) (T = 4 ms) and has risen
    back by half its depth at 5T/6; perforation ends the impactor's part at once; a record
    that stops before either: None."""
    from cases.slab.quantities import NAMES, event_ends
    t = np.linspace(0.0, 4e-3, 4001)
    q = np.zeros((len(t), len(NAMES)))
    q[:, NAMES.index("impactor_vz")] = -10.0 + 1e4 * t
    q[:, NAMES.index("penetration")] = 0.1
    q[:, NAMES.index("deflection_x1.25")] = -np.sin(np.pi * t / 4e-3)
    ends = event_ends(t, q)
    assert ends["impactor_s"] == pytest.approx(0.99e-3, abs=1.5e-6)
    assert ends["slab_s"] == pytest.approx(5 / 6 * 4e-3, abs=1.5e-6)
    event_end = lambda t, q: event_ends(t, q)["slab_s"]
    assert event_end(t[:3000], q[:3000]) is None           # not risen by half yet
    slow = q.copy()
    slow[:, NAMES.index("impactor_vz")] = -10.0 + 1e3 * t  # still -6 m/s at the end
    assert event_end(t, slow) is None
    slow[2000:, NAMES.index("penetration")] = 0.3          # perforated at t = 2 ms
    slow[:, NAMES.index("deflection_x1.25")] = -np.sin(np.pi * (t - 2e-3) / 4e-3) * (t > 2e-3)
    assert event_end(t, slow) is None                      # the centre still sinks
    slow[:, NAMES.index("deflection_x1.25")] = -np.sin(np.pi * t / 2.2e-3)
    assert event_end(t, slow) == t[2000]                   # risen past half by then


def test_the_default_window_is_the_impact_s_measured_duration():
    """Measured speeds give their duration; a speed between two the longer of them, beyond
    them the nearest; a scale without measurements its table's 7 ms; the steps hold it."""
    from cases.slab.scales import DURATIONS, TABLE_DURATION, duration
    measured = DURATIONS["small"]
    assert duration("small", 10) == measured[10] and duration("small", 40) == measured[40]
    assert duration("small", 20) == max(measured[10], measured[40])
    assert duration("small", 5) == measured[10] and duration("small", 80) == measured[40]
    assert duration("medium", 40) == TABLE_DURATION
    spec = slab.SlabSpec(scale="small", impactor_speed=10)
    assert spec.steps == int(np.ceil(round(4950 * measured[10] / TABLE_DURATION * 0.15 / 0.3, 6)))


def test_the_strength_that_matches_a_peak_is_found_on_an_increasing_curve():
    """Secant steps find the root of an affine peak in one step after the two first probes
    (exact), and of a curved one (peak = 10 x^0.8) within the tolerance from below and from
    above; a first guess that matches is kept."""
    from cases.slab.bending import increasing_root
    x, tried = increasing_root(lambda x: 3.0 * x + 10.0, 1.0, 19.0, 1e-12)
    assert x == pytest.approx(3.0, rel=1e-12) and len(tried) == 3
    x, tried = increasing_root(lambda x: 10.0 * x ** 0.8, 1.0, 20.0, 1e-4)
    assert 10.0 * x ** 0.8 == pytest.approx(20.0, rel=1e-4)
    assert x == pytest.approx(2.0 ** 1.25, rel=2e-4)
    x, tried = increasing_root(lambda x: 10.0 * x ** 0.8, 1.0, 5.0, 1e-4)   # from above
    assert x == pytest.approx(0.5 ** 1.25, rel=2e-4)
    assert increasing_root(lambda x: 2.0 * x, 3.0, 6.0, 1e-9) == (3.0, [[3.0, 6.0]])
    with pytest.raises(ValueError, match="must be > 0"):
        increasing_root(lambda x: x, 1.0, 0.0, 1e-3)
    with pytest.raises(RuntimeError, match="does not grow"):
        increasing_root(lambda x: 5.0, 1.0, 7.0, 1e-3)


@pytest.mark.parametrize("args, message", [
    (["--fe-ratio", "-1"], "slab: fe_ratio must be in (0, 20], got -1.0"),
    (["--fe-strength-for-peak", "0"], "--fe-strength-for-peak must be > 0 newtons, got 0.0"),
    (["--fe-ratio", "x"], "argument --fe-ratio: invalid float value: 'x'"),
])
def test_the_bending_tool_refuses_a_bad_value_in_one_line(capsys, args, message):
    from cases.slab.bending import main as bending
    with pytest.raises(SystemExit) as e:
        bending(args)
    err = capsys.readouterr().err
    assert e.value.code == 2 and message in err and len(err.strip().splitlines()) == 1
