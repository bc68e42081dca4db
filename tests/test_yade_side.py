"""The YADE partner against exact answers."""
import numpy as np
import pytest

from yade_side import import_yade
from yade_side.bulk import BodySet, quaternion_product, rotation_quaternion
from yade_side.chain import build_chain
from yade_side.damage import LinkDamage, keep_links_elastic
from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene

yade = import_yade()
O = yade.Omega()
EPS = np.finfo(float).eps


def concrete(**kw):
    params = dict(young=30e9, poisson=0.2, frictionAngle=0.67, sigmaT=3e6, epsCrackOnset=1e-4,
                  relDuctility=30, density=4000)
    params.update(kw)
    return O.materials.append(yade.wrapper.CpmMat(**params))


def cluster(n=4, R=0.01, gap=0.0, **kw):
    """n spheres on a line, `gap` apart (touching: n − 1 cohesive links)."""
    reset_scene()
    from yade import utils
    mat = concrete(**kw)
    ids = O.bodies.append([utils.sphere(((2 * R + gap) * i, 0.0, 0.0), R, material=mat) for i in range(n)])
    return list(ids)


@pytest.mark.parametrize("direct", [True, False])
def test_bulk_state_equals_per_body_state(direct):
    """Both exchange paths (numpy in YADE's memory, YADE's bulk API) read and write exactly
    what YADE's per-body attributes hold."""
    ids = cluster()
    cpm_engines()
    rng = np.random.default_rng(0)
    for i in ids:
        O.bodies[i].state.vel = tuple(rng.normal(size=3))
        O.bodies[i].state.angVel = tuple(rng.normal(size=3))
    O.step()
    bs = BodySet(ids, direct=direct)
    assert bs.direct == direct  # the memory layout is found and verified on this YADE build
    for j, i in enumerate(ids):
        s = O.bodies[i].state
        assert np.array_equal(bs.pos[j], np.array(s.pos))
        assert np.array_equal(bs.vel[j], np.array(s.vel))
        assert np.array_equal(bs.angvel[j], np.array(s.angVel))
        assert np.array_equal(bs.ori[j], [s.ori[k] for k in range(4)])  # x, y, z, w
        assert bs.mass[j] == s.mass and bs.inertia[j] == s.inertia[0]
    # a write goes back body by body
    bs.state[:, 3:6] = rng.normal(size=(len(ids), 3))
    bs.write()
    bs.state[:, 9:13] = rotation_quaternion(rng.normal(size=(len(ids), 3)))
    bs.write()
    for j, i in enumerate(ids):
        s = O.bodies[i].state
        assert np.array_equal(np.array(s.vel), bs.vel[j])
        assert np.array_equal([s.ori[k] for k in range(4)], bs.ori[j])


@pytest.mark.parametrize("direct", [True, False])
def test_joined_and_subset_sets_are_the_sets_of_their_bodies(direct):
    """BodySet.joined and .subset (a zone grown in place) take their sets' places in memory:
    they read and write what a set made afresh of the same bodies does, bit for bit, bodies
    appended to the scene after the first set was made, masses as they are now."""
    from yade import utils
    ids = cluster(n=6)
    cpm_engines()
    first = BodySet(ids[:4], direct=direct)
    more = list(O.bodies.append([utils.sphere((0.0, 0.05 * k, 0.0), 0.01,
                                              material=O.bodies[0].material) for k in (1, 2)]))
    second = BodySet(ids[4:] + more, direct=direct)
    O.bodies[ids[1]].state.mass *= 0.5
    joined = BodySet.joined(first, second)
    rows = [5, 0, 7, 2]
    subset = joined.subset(rows)
    every = ids + more
    fresh, fresh_rows = BodySet(every, direct=direct), BodySet([every[r] for r in rows], direct=direct)
    assert joined.direct == subset.direct == direct
    rng = np.random.default_rng(5)
    for a, b in ((joined, fresh), (subset, fresh_rows)):
        assert np.array_equal(a.ids, b.ids) and np.array_equal(a.radius, b.radius)
        assert np.array_equal(a.mass, b.mass) and np.array_equal(a.inertia, b.inertia)
        a.state[:] = rng.normal(size=a.state.shape)
        a.write()
        assert np.array_equal(b.read().view(np.int64), a.state.view(np.int64))
        b.state[:] = rng.normal(size=b.state.shape)
        b.write()
        assert np.array_equal(a.read().view(np.int64), b.state.view(np.int64))
    assert joined.mass[1] == 0.5 * first.mass[1]


def test_direct_and_api_paths_agree_bit_for_bit():
    ids = cluster(n=6)
    cpm_engines()
    direct, api = BodySet(ids), BodySet(ids, direct=False)
    rng = np.random.default_rng(4)
    direct.state[:] = rng.normal(size=(6, 13))
    direct.write()
    assert np.array_equal(api.read().view(np.int64), direct.state.view(np.int64))
    api.state[:] = rng.normal(size=(6, 13))
    api.write()
    assert np.array_equal(direct.read().view(np.int64), api.state.view(np.int64))


def test_memory_view_is_refused_when_yade_api_does_not_confirm_it():
    """The direct view is only used when the API's values are found in memory: a `put`
    that writes nothing (so the probe values never appear) gives no view."""
    from yade_side.memory import locate
    ids = cluster(n=3)
    subdomain = yade.wrapper.Subdomain()
    assert locate(O, ids, subdomain.getStateValuesFromIds,
                  subdomain.setStateValuesFromIds) is not None
    assert locate(O, ids, subdomain.getStateValuesFromIds, lambda i, v: None) is None


def test_memory_view_refuses_a_replaced_scene():
    """After O.reset the located States are no longer simulated: reads and writes stop with
    an error instead of touching them."""
    from yade_side.memory import SceneReplaced, locate
    ids = cluster(n=3)
    subdomain = yade.wrapper.Subdomain()
    memory = locate(O, ids, subdomain.getStateValuesFromIds, subdomain.setStateValuesFromIds)
    out = np.empty((3, 13))
    memory.read(out)
    cluster(n=3)  # a new scene with bodies of the same ids
    with pytest.raises(SceneReplaced, match="replaced"):
        memory.read(out)
    with pytest.raises(SceneReplaced, match="replaced"):
        memory.write(out)


@pytest.mark.parametrize("direct", [True, False])
def test_correction_is_an_exact_central_difference_update(direct):
    """YADE's step + correct(dd) equals the central difference with the correction's force
    f = m dd / Δt² added: x(n+1) = 2 x(n) − x(n−1) + Δt² (F + f)/m, to round-off."""
    ids = cluster(n=3)
    cpm_engines()
    create_cohesive_links()
    bs = BodySet(ids, direct=direct)
    dt = O.dt
    rng = np.random.default_rng(1)
    bs.set_velocity(rng.normal(size=(3, 3)) * 0.1)
    history = [bs.read()[:, :3].copy()]
    O.step()
    bs.predict(dt)
    history.append(bs.pos.copy())
    for _ in range(5):
        O.step()
        forces = np.array([O.forces.f(int(i)) for i in ids])  # F(x_n), used by this step
        bs.predict(dt)
        dd = rng.normal(size=(3, 3)) * 1e-9
        bs.correct(dd, np.zeros((3, 3)), dt)
        expected = 2 * history[-1] - history[-2] + dt**2 * forces / bs.mass[:, None] + dd
        scale = np.abs(history[-1]).max()
        assert np.allclose(bs.read()[:, :3], expected, rtol=0, atol=64 * EPS * scale)
        history.append(bs.pos.copy())


def test_rotation_correction_turns_orientation_and_accumulates_rotation_vector():
    ids = cluster(n=2, gap=0.1)  # apart: no link, no torque
    cpm_engines()
    bs = BodySet(ids)
    dt = O.dt
    w = np.array([[0.0, 0.0, 2.0], [1.0, -1.0, 0.5]])
    bs.set_velocity(np.zeros((2, 3)), w)
    O.step()
    bs.predict(dt)
    assert np.allclose(bs.rotation_pred, dt * w, rtol=1e-15)
    dtheta = np.array([[0.0, 0.0, 1e-3], [0.0, 0.0, 0.0]])
    bs.correct(np.zeros((2, 3)), dtheta, dt)
    # orientation = rotation of (dt w) then dθ; for sphere 0 both are about z: angles add
    angle = np.linalg.norm(np.array(O.bodies[int(ids[0])].state.ori.toAxisAngle()[1]))
    assert angle == pytest.approx(2 * dt + 1e-3, rel=1e-12)
    assert np.allclose(bs.rotation[0], [0, 0, 2 * dt + 1e-3], rtol=1e-15)
    assert np.allclose(bs.angvel[0], [0, 0, 2 + 1e-3 / dt], rtol=1e-15)


def test_quaternion_helpers():
    rng = np.random.default_rng(2)
    theta = rng.normal(size=(5, 3))
    q = rotation_quaternion(theta)
    assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-15)
    # two rotations about the same axis compose into the sum of angles
    half = rotation_quaternion(0.5 * theta)
    assert np.allclose(quaternion_product(half, half), q, atol=1e-15)
    assert np.allclose(rotation_quaternion(np.zeros((1, 3))), [[0, 0, 0, 1]])


def test_damage_counts_broken_over_initial_links():
    """A chain of 4: pull the last sphere away by far more than the links' strain at
    failure: its one link breaks; damage = 0, 0, 1/2, 1 for the four spheres."""
    ids = cluster(n=4)
    cpm_engines()
    create_cohesive_links()
    dmg = LinkDamage(ids)
    assert dmg.record_initial().tolist() == [1, 2, 2, 1]
    last = O.bodies[int(ids[-1])]
    for b in O.bodies:
        b.state.blockedDOFs = "xyzXYZ"
    last.state.vel = (10.0, 0, 0)
    O.dt = 1e-7
    # 2e-4 m on a 2e-2 m link: strain κ = 1e-2; CPM's ω = 1 − (ε0/κ) exp(−(κ − ε0)/(30 ε0))
    # = 0.9996 > 0.99 with ε0 = 1e-4
    for _ in range(200):
        O.step()
    assert dmg.update().tolist() == [0.0, 0.0, 0.5, 1.0]
    assert dmg.broken_links() == 1
    # the broken link is gone (ω > 0.99) and counts as 1; the two others were never strained
    pairs, omega = dmg.link_omega()
    assert sorted(zip(map(tuple, np.sort(pairs, axis=1).tolist()), omega.tolist())) == [
        ((0, 1), 0.0), ((1, 2), 0.0), ((2, 3), 1.0)]


def test_link_omega_leaves_out_links_of_unmeasured_spheres():
    """Two chains of 2 (links 0-1, 2-3), only the first measured; then the first measured alone
    with its partner unmeasured: that link's far end is -1."""
    reset_scene()
    from yade import utils
    mat = concrete()
    ids = O.bodies.append([utils.sphere((x, 0.0, 0.0), 0.01, material=mat)
                           for x in (0.0, 0.02, 0.1, 0.12)])
    cpm_engines()
    create_cohesive_links()
    first = LinkDamage(ids[:2])
    first.record_initial()
    assert [p.tolist() for p in first.link_omega()] == [[[0, 1]], [0.0]]
    one = LinkDamage(ids[1:2])
    one.record_initial()
    pairs, omega = one.link_omega()
    assert sorted(pairs[0].tolist()) == [-1, 0] and omega.tolist() == [0.0]


def test_worst_link_reads_each_spheres_most_damaged_link():
    """The chain of 4, its last sphere pulled by 5e-6 m (κ = 2.5e-4 on the 2e-2 m link, ε0 =
    1e-4): CPM's ω = 1 − (ε0/κ) exp(−(κ − ε0)/(30 ε0)) = 0.6195 on that link, read by
    worst_link for its two spheres; then pulled past failure, the deleted link counts as 1."""
    ids = cluster(n=4)
    cpm_engines()
    create_cohesive_links()
    dmg = LinkDamage(ids)
    dmg.record_initial()
    for b in O.bodies:
        b.state.blockedDOFs = "xyzXYZ"
    last = O.bodies[int(ids[-1])]
    last.state.vel = (10.0, 0, 0)
    O.dt = 1e-7
    for _ in range(5):
        O.step()
    last.state.vel = (0.0, 0, 0)
    O.step()
    omega = O.interactions[int(ids[2]), int(ids[3])].phys.omega
    kappa = (last.state.pos[0] - last.state.refPos[0]) / 0.02
    assert omega == pytest.approx(1 - (1e-4 / kappa) * np.exp(-(kappa - 1e-4) / 3e-3), rel=1e-9)
    assert dmg.worst_link().tolist() == [0.0, 0.0, omega, omega]
    last.state.vel = (10.0, 0, 0)
    for _ in range(200):
        O.step()
    assert dmg.worst_link().tolist() == [0.0, 0.0, 1.0, 1.0]


def test_links_kept_elastic_never_damage():
    """The same pull with the pulled link (midpoint x = 5 R) kept elastic: no link breaks and
    that link's damage stays exactly 0; the other links are left as they were."""
    ids = cluster(n=4)
    cpm_engines()
    create_cohesive_links()
    dmg = LinkDamage(ids)
    dmg.record_initial()
    assert keep_links_elastic(lambda p: p[:, 0] > 0.045) == 1
    for b in O.bodies:
        b.state.blockedDOFs = "xyzXYZ"
    O.bodies[int(ids[-1])].state.vel = (10.0, 0, 0)
    O.dt = 1e-7
    for _ in range(200):
        O.step()
    assert dmg.update().tolist() == [0.0, 0.0, 0.0, 0.0]
    elastic = {(min(i.id1, i.id2), max(i.id1, i.id2)): i.phys.neverDamage for i in O.interactions}
    assert elastic == {(ids[0], ids[1]): False, (ids[1], ids[2]): False, (ids[2], ids[3]): True}
    assert O.interactions[int(ids[2]), int(ids[3])].phys.omega == 0


def test_chain_carries_a_long_wave_at_its_link_speed():
    """A 1D chain with k = E A/L and m = ρ A L: a smooth pulse (40 spacings wide) travels
    at c = L √(k/m) = √(E/ρ). Leap-frog on the chain at Courant number C slows a Gaussian of
    width σ by about (1 − C²)(L/σ)²/16 = 4.7e-4 here; allow twice that."""
    reset_scene()
    E, rho, L = 30e9, 2400.0, 0.01
    A = L * L
    n = 400
    ids = build_chain((0, 0, 0), L, n, E, rho, A)
    cpm_engines(dt=0.5 * L / np.sqrt(E / rho))
    create_cohesive_links()
    assert len([i for i in O.interactions]) == n - 1
    c = np.sqrt(E / rho)
    bs = BodySet(ids)
    x = bs.ref_pos[:, 0]
    sigma = 10 * L
    # right-going wave: u = f(x − c t), v = −c f'
    f = lambda s: 1e-6 * np.exp(-0.5 * ((s - 1.0) / sigma) ** 2)
    dt = O.dt
    bs.state[:, 0] = x + f(x)
    bs.state[:, 3] = -c * np.gradient(f(x + 0.5 * c * dt), x)  # at t = −Δt/2
    bs.write()
    steps = 400  # 2 m of travel, the pulse stays 1 m from the end
    for _ in range(steps):
        O.step()
    u = bs.read()[:, 0] - x
    t = steps * dt
    centre = np.sum(x * u) / np.sum(u)
    speed = (centre - 1.0) / t
    assert speed == pytest.approx(c, rel=2 * 0.75 * (L / sigma) ** 2 / 16)


def test_sphere_series_reads_back(tmp_path):
    from yade_side.output import SphereSeries, read_series
    rng = np.random.default_rng(3)
    series = SphereSeries(tmp_path / "spheres.pvd")
    frames = []
    for t in (0.0, 1e-3):
        c, r, d, dmg = rng.normal(size=(7, 3)), rng.random(7), rng.normal(size=(7, 3)), rng.random(7)
        series.write(t, c, r, displacement=d, damage=dmg)
        frames.append((t, c, r, d, dmg))
    back = read_series(tmp_path / "spheres.pvd")
    assert [t for t, _ in back] == [0.0, 1e-3]
    for (t, c, r, d, dmg), (_, mesh) in zip(frames, back):
        assert np.array_equal(mesh.points, c)
        assert np.array_equal(mesh.point_data["radius"], r)
        assert np.array_equal(mesh.point_data["displacement"], d)
        assert np.array_equal(mesh.point_data["damage"], dmg)
    with pytest.raises(ValueError, match="damage"):
        series.write(0.0, c, r, damage=dmg[:3])


def test_a_resumed_sphere_series_keeps_its_first_frames(tmp_path):
    from yade_side.output import SphereSeries, read_series
    c, r = np.zeros((2, 3)), np.ones(2)
    series = SphereSeries(tmp_path / "spheres.pvd")
    for t in (0.0, 1.0, 2.0):
        series.write(t, c + t, r)
    resumed = SphereSeries(tmp_path / "spheres.pvd", frames=2)
    resumed.write(5.0, c + 5.0, r)
    back = read_series(tmp_path / "spheres.pvd")
    assert [t for t, _ in back] == [0.0, 1.0, 5.0]
    assert np.array_equal(back[2][1].points, c + 5.0)
    with pytest.raises(ValueError, match="it has 3 frames, 4 expected"):
        SphereSeries(tmp_path / "spheres.pvd", frames=4)
