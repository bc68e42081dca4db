"""A DE zone grown during the run (orchestrator.run.grow), against a known answer: a block in
uniform strain and uniform velocity, u = ε₀ x + v₀ t, whose outer faces move so. That field is
an exact solution of the FE part and of a simple cubic lattice of spheres (its links cancel
in opposite pairs), and with the FE's bulk modulus the lattice's own, of the coupled model
too (to the band's discretisation) when the strain is hydrostatic: converting FE cells to
spheres mid-run must leave the stress and the energy as they were."""
from types import SimpleNamespace

import numpy as np
import pytest

R = 0.005                     # sphere radius (m): lattice spacing 2R
H = 4 * R                     # FE cells: 2 × 2 × 2 spheres each
N = 9                         # cells along each side of the cube
L = N * H
EPS0 = 2e-4                   # hydrostatic strain
V0 = np.array([0.3, -0.2, 0.4])   # m/s
NU = 0.25                     # the FE's Poisson ratio (the lattice's K is what must match)
PRE = 60                      # steps before the conversion
SCENE = SimpleNamespace(packing="cubic", de_hi=np.full(3, L), radius=R, contact_young=33e9,
                        contact_poisson=0.2, density=2400.0)


def field(x, t):
    return EPS0 * x + V0 * t


def lattice_bulk_modulus():
    """K of the lattice from its own links: under ε₀ I, a sphere's 3 face links (length 2R)
    and 6 edge links (2√2 R) give σ = ε₀ (kn_face + 4 kn_edge) / 2R in every direction."""
    from cases.block3d.model import BlockScene
    from orchestrator.builder import Description, assemble
    from yade_side import import_yade
    small = SimpleNamespace(**{**vars(SCENE), "de_hi": np.full(3, 4 * R)})
    assemble(Description(BlockScene(small), dt_safety=0.5))
    kn = {}
    for i in import_yade().Omega().interactions:
        kn.setdefault(round(i.phys.refLength / (2 * R), 6), i.phys.kn)
    assert sorted(kn) == [1.0, round(np.sqrt(2), 6)]
    return (kn[1.0] + 4 * kn[round(np.sqrt(2), 6)]) / (2 * R) / 3


def growing_block(K):
    from cases.block3d.check import PrescribedFE
    from cases.block3d.model import BlockScene
    from fenicsx_side.cells import box_mesh_without_cells
    from fenicsx_side.model import ElasticModel
    from orchestrator.builder import CouplingSpec, Description, Model, assemble
    from orchestrator.coupling.bridging import Bridging
    from orchestrator.coupling.cells import CellGrid
    from orchestrator.run.autozone import TripLevels
    from orchestrator.run.grow import GrowingModel
    grid = CellGrid((0, 0, 0), (L, L, L), (N, N, N), axes=(0, 1, 2))
    young = 3 * K * (1 - 2 * NU)
    dt = []

    def build(mask, grown_from=None, earlier=()):
        def fe(weight):
            model = ElasticModel(box_mesh_without_cells((0, 0, 0), (L, L, L), (N,) * 3, mask),
                                 young, NU, SCENE.density, weight=weight)
            x = model.nodes
            outer = np.flatnonzero(((x < 1e-9) | (x > L - 1e-9)).any(axis=1))
            dofs = (3 * outer[:, None] + np.arange(3)).ravel()
            return PrescribedFE(model, dofs, lambda t: field(model.nodes, t).ravel())
        keeps = [Bridging(grid.zone(m), 1, H).covers for m in earlier]
        d = Description(BlockScene(SCENE, keeps), fe, Bridging(grid.zone(mask), 1, H),
                        CouplingSpec("full", 1.0, True, "consistent"), dt_safety=0.5,
                        dt=dt[0] if dt else None)
        m = Model(assemble(d, grown_from))
        dt[:] = [m.dt]
        return m

    start = np.zeros(grid.shape, bool)
    start[4, 4, 4] = True
    limit = grid.dilate(start, 2)
    block = GrowingModel(build, grid, start, limit, np.inf, TripLevels(), tol=1e-9,
                         log=lambda line: None)
    start_exact(block.current, 0.0)
    return block, grid, young


def mean_stress(model):
    """The FE part's volume-average stress (its cells are equal cubes)."""
    return model.fe.stress().tensor.mean(axis=0)


def link_stress(ids):
    """Mean of CPM's normal stress σN over the links between the bodies `ids` (an
    unweighted stress: the band's weights are in the forces, not in σN)."""
    from yade_side import import_yade
    ids = set(int(i) for i in ids)
    return np.mean([i.phys.sigmaN for i in import_yade().Omega().interactions
                    if i.isReal and i.id1 in ids and i.id2 in ids])


def start_exact(model, t):
    """The model in the exact state u = ε₀ x + v₀ t (spheres, FE nodes)."""
    s = model.spheres
    s.read()
    s.pos[:] = s.ref_pos + field(s.ref_pos, t)
    s.vel[:] = V0
    s.write()
    fe = model.fe.fe              # the FE model inside its prescribed-motion wrapper
    fe.u = field(fe.nodes, t).ravel()
    fe.v = np.tile(V0, len(fe.nodes))
    fe.t = t


def test_a_block_in_uniform_strain_and_velocity_keeps_its_stress_and_energy_when_cells_convert():
    """Converted mid-run, the block keeps its energy within 1 % over 200 further steps and
    its FE stress within 2 %; the converted links' stress follows, within 2 %, what the model
    of the grown zone does when started in the exact state at that time: the conversion's
    own error, apart from the band's discretisation, which swings both by a few %."""
    from orchestrator.run.autozone import Tripped
    from yade_side.scene import settle_forces
    K = lattice_bulk_modulus()
    block, grid, young = growing_block(K)
    first = block.current
    # sensors: the zone's first sphere, and an FE node of a cell that will convert (then
    # read from the sphere nearest it)
    node = int(np.argmin(np.linalg.norm(first.fe.nodes - H * np.array([3, 4, 4]), axis=1)))
    assert np.allclose(first.fe.nodes[node], H * np.array([3, 4, 4]))
    first.set_sensors(["sphere", "node"], [0], [node],
                      [first.spheres.ref_pos[0], first.fe.nodes[node]])
    exact = 3 * K * EPS0
    link_exact = SCENE.contact_young * EPS0        # a link's σN under ε₀ I
    for _ in range(PRE):
        block.step()
    old = block.current
    # the FE before: σ = 3 K ε₀ I on average (cell by cell to the band's discretisation)
    assert np.abs(mean_stress(old) / exact - np.eye(3)).max() < 0.02
    settle_forces()
    before = old.energy()
    # the FE cells just outside the band trip: with their margin, two cell layers convert
    block.grow(Tripped(PRE, "test", grid.dilate(block.zone, 2) & ~grid.dilate(block.zone, 1)))
    new = block.current
    record = block.conversions[-1]
    assert record["zone_cells"] == 5 ** 3 and len(record["cells"]) == 5 ** 3 - 1
    # what tripped: the 98 cells two layers out, none of them in the one-layer band
    assert len(record["tripped_cells"]) == 5 ** 3 - 3 ** 3 and record["tripped_in_band"] == 0
    assert record["spheres_added"] == 14 ** 3 - 6 ** 3
    assert record["energy_before"] == pytest.approx(before, rel=1e-12)
    energies = [record["energy_after"]]
    # the converted cells that are DE zone now: their links carry the FE's strain
    def was(model):     # its spheres that the model before the conversion had
        return (np.abs(model.spheres.ref_pos[:, None, :] - old.spheres.ref_pos[None])
                .max(axis=2) < 1e-9).any(axis=1)
    # grown in place: the old model's spheres first, as they were, then the added ones
    assert np.array_equal(new.spheres.ids[:len(old.spheres)], old.spheres.ids)
    assert was(new).sum() == len(old.spheres) and not was(new)[len(old.spheres):].any()
    converted = new.spheres.ids[new.in_de_zone & ~was(new)]
    assert len(converted) == (5 ** 3 - 3 ** 3) * 8
    # the seam: the new links with an old sphere at one end, counted here from the reference
    # positions (centres within 1.5 × the sum of the radii)
    from scipy.spatial import cKDTree
    ref, n_old = new.spheres.ref_pos, len(old.spheres)
    seam_pairs = cKDTree(ref[n_old:]).query_ball_point(ref[:n_old], 1.5 * 2 * R * (1 + 1e-12))
    seam = record["new_links_energy"]["seam"]
    assert seam["links"] == sum(map(len, seam_pairs)) > 0
    assert seam["of"] == len(new.parts.new_links)
    assert 0 < seam["normal"] < record["new_links_energy"]["normal"]
    assert abs(link_stress(converted) / link_exact - 1) < 0.02
    stress = []
    for _ in range(200):
        block.step()
        energies.append(new.energy())
        stress.append(link_stress(converted) / link_exact)
    assert np.abs(mean_stress(new) / exact - np.eye(3)).max() < 0.02
    assert np.abs(np.array(energies) / before - 1).max() < 0.01
    # the body moves on with its velocity: every sphere at ref + ε₀ ref + v₀ t, and so do
    # the sensors, the node's now read from a sphere
    s, t = new.spheres, (PRE + 200) * block.dt
    s.read()
    assert np.abs(s.pos - s.ref_pos - field(s.ref_pos, t)).max() < 0.02 * EPS0 * L
    assert new.sensor_names == ["sphere", "node"] and len(new._sensor_nodes) == 0
    # (the sphere nearest the node is √3 R from it at most: ε₀ √3 R apart in the field)
    assert np.abs(new.sensor_displacements() - field(new.sensor_positions, t)).max() < \
        0.02 * EPS0 * L + EPS0 * np.sqrt(3) * R
    # the grown zone's model started exactly at the conversion's time
    reference = block.build(block.zone)
    start_exact(reference, PRE * block.dt)
    same = reference.spheres.ids[reference.in_de_zone & ~was(reference)]
    exact_start = []
    for _ in range(200):
        reference.step()
        exact_start.append(link_stress(same) / link_exact)
    assert np.abs(np.array(stress) - np.array(exact_start)).max() < 0.02


@pytest.mark.parametrize("options, message", [
    (dict(zone="grow", reinforced=True), r"^slab: zone 'grow' does not carry the bars' state"),
    (dict(zone="grow", zone_cells=((7, 5),)), r"^slab: zone cells make a fixed zone, not one of "
                                              r"zone 'grow'$"),
    (dict(zone_cells=((15, 0),)), r"^slab: zone cells must be \(i, j\) indices of the slab's "
                                  r"in-plane FE cells at scale 'small', got \(\(15, 0\),\)$"),
    (dict(zone_cells="x"), r"^slab: zone cells must be .* got x$"),
])
def test_slab_refuses_bad_growing_or_fixed_cell_zones(options, message):
    from cases.slab import SlabSpec
    with pytest.raises(ValueError, match=message) as e:
        SlabSpec(**options)
    assert "\n" not in str(e.value)


def test_a_growing_zone_needs_a_yade_whose_memory_layout_was_verified(monkeypatch):
    from orchestrator.run.grow import GrowingModel
    from yade_side import import_yade, memory
    import_yade()
    monkeypatch.setattr(memory, "VERIFIED", ("0.0",))
    with pytest.raises(ValueError, match=r"^a zone that grows during the run writes its new "
                                         r"links in YADE's memory, .* verified on YADE 0.0 only, "
                                         r"not on this YADE \S+$"):
        GrowingModel(*[None] * 7)


def test_a_fixed_zone_of_cells_is_that_zone(tmp_path):
    """--zone-from DIR reads the cells the run in DIR ended with; the model's grid is made of
    them; a run that did not end clean is refused with one line."""
    import json
    from cases.slab import SlabSpec
    from cases.slab.zone import model_grid
    from cli.commands.slab import _zone_run
    cells = [[6, 5], [6, 6], [7, 5], [7, 6]]
    (tmp_path / "summary.json").write_text(json.dumps(
        {"zone_outcome": "clean", "zone_final": {"cells": cells}}))
    spec = SlabSpec(zone_cells=_zone_run(tmp_path)["zone_final"]["cells"])
    grid = model_grid(spec)
    assert np.argwhere(grid.cells).tolist() == cells and grid.cells.sum() == 4
    (tmp_path / "summary.json").write_text(json.dumps({"zone_outcome": "limit"}))
    with pytest.raises(ValueError, match=r"^--zone-from .*: not a zone 'auto' or 'grow' run "
                                         r"that ended clean \(zone_outcome 'limit'\)$"):
        _zone_run(tmp_path)


def test_history_and_normal_blocks_read_and_write_what_yades_python_view_reads():
    """The CPM history of many links in one gather/scatter (yade_side.memory.HistoryBlocks),
    and their geometries' normals, are what Python reads of each, bit for bit, and a write
    is read back so."""
    from yade_side import import_yade
    from yade_side.material import ConcreteParams, cpm_material
    from yade_side.memory import (NORMAL_WIDTH, WIDTH, Blocks, HistoryBlocks,
                                   find_normal_offset, find_offset, history_values, same_bits)
    from yade_side.packing import add_spheres
    from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene
    yade = import_yade()
    O = yade.Omega()
    reset_scene()
    centres = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0.01, 0.01, 0.002]])
    add_spheres(centres, np.full(4, 0.005), cpm_material(ConcreteParams(), 0.6))
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    O.bodies[1].state.vel = yade.Vector3(1.0, 0.3, -0.2)       # stretches and shears links
    for _ in range(60):
        O.step()
    links = [i for i in O.interactions if i.isReal]
    phys = [i.phys for i in links]
    assert len(links) == 6 and max(p.omega for p in phys) > 0
    blocks = HistoryBlocks(phys, find_offset(links))
    values = blocks.read()
    assert same_bits(values, [history_values(p) for p in phys])
    values[:, 16:19] += 1e-5                       # epsT
    blocks.write(values)
    assert same_bits(values, [history_values(p) for p in phys])
    # the geometries' normals likewise (a rotated normal: still exactly what Python reads)
    geoms = [i.geom for i in links]
    normals = Blocks(geoms, find_normal_offset(geoms), NORMAL_WIDTH)
    n = normals.read()
    assert same_bits(n, [tuple(g.normal) for g in geoms])
    turned = n[:, [1, 2, 0]]
    normals.write(turned)
    assert same_bits(turned, [tuple(g.normal) for g in geoms])
    # named fields (yade_side.memory.Fields): found by probing one link, which is left as it
    # was; read and written as Python reads them, scalars and vectors
    from yade_side import memory
    from yade_side.memory import Fields
    memory._field_found.clear()              # probed here, whichever test probed first
    names = ("kn", "ks", "refLength", "E", "normalForce", "shearForce")
    read = lambda p: [getattr(p, k) for k in names[:4]] + [
        tuple(getattr(p, k)) for k in names[4:]] + [history_values(p)]
    before = [read(p) for p in phys]
    fields = Fields(phys, names)
    for p, b in zip(phys, before):
        assert read(p)[:6] == b[:6] and same_bits(read(p)[6], b[6])
    assert same_bits(fields.read("kn"), [p.kn for p in phys])
    assert same_bits(fields.read("shearForce"), [tuple(p.shearForce) for p in phys])
    fields.write(refLength=fields.read("refLength") * 1.5, normalForce=-fields.read("normalForce"))
    assert same_bits([p.refLength for p in phys], [1.5 * b[2] for b in before])
    assert same_bits([tuple(p.normalForce) for p in phys], [[-v for v in b[4]] for b in before])
    history = find_offset(links), WIDTH                  # a block found elsewhere, likewise
    assert same_bits(fields.read_block(*history), [history_values(p) for p in phys])
    fields.write_block(*history, blocks.read() * 2)
    assert same_bits([history_values(p) for p in phys], values * 2)


def test_affine_shear_strain_of_links():
    """epsT is the tangential relative displacement over the link's length (measured on
    YADE: a velocity δ/Δt for one step gives δ/refLength): nil under a rigid rotation with
    contact-point arms, (ε n)_t under a pure strain, and the rotation's part (1 − r) W n with
    arms r L."""
    from orchestrator.run.grow import affine_shear_strain
    rng = np.random.default_rng(3)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    B = rng.normal(size=(50, 3, 3)) * 1e-4
    eps, W = 0.5 * (B + B.transpose(0, 2, 1)), 0.5 * (B - B.transpose(0, 2, 1))
    tangential = lambda v: v - np.einsum("pa,pa->p", v, n)[:, None] * n
    assert np.abs(affine_shear_strain(W, n, np.ones(50))).max() < 1e-20
    assert np.allclose(affine_shear_strain(eps, n, np.full(50, 0.7)),
                       tangential(np.einsum("pab,pb->pa", eps, n)), rtol=1e-12, atol=1e-19)
    assert np.allclose(affine_shear_strain(W, n, np.full(50, 0.7)),
                       tangential(0.3 * np.einsum("pab,pb->pa", W, n)), rtol=1e-12, atol=1e-19)


def test_gaps_carry_on_harmonically_into_the_new_bodies():
    """continued_gaps on a simple cubic lattice (links to the 6 face and 12 edge neighbours:
    a linear field is harmonic there): a linear gap at the old bodies around a block of new
    ones comes back exactly inside; a gap of 0 at the new band pulls it to 0 there; bodies
    the FE does not cover give no gap; new bodies linked to no known one take 0."""
    from orchestrator.run.grow import continued_gaps
    n = 9
    grid = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    ref = 2 * R * grid.astype(float)
    radius = np.full(len(ref), R)
    inner = np.all((grid > 0) & (grid < n - 1), axis=1)
    free, old = np.flatnonzero(inner), np.flatnonzero(~inner)
    A = np.array([[1.0, -2.0, 0.5], [0.3, 0.0, 1.0], [2.0, 1.0, -1.0]]) * 1e-3
    du, dv = lambda x: (x - 0.04) @ A.T, lambda x: x @ A
    motion = lambda j: (du(ref[j]), dv(ref[j]))
    zero = lambda j: (np.zeros((len(j), 3)), np.zeros((len(j), 3)))
    everywhere = lambda j: np.ones(len(j), bool)
    gaps = continued_gaps(ref, radius, free, np.arange(0), motion, everywhere, zero)
    exact = np.hstack([du(ref[free]), dv(ref[free])])
    # the diagonal's 1e-12 regularisation, times the lattice's condition (~(n/π)²)
    assert np.abs(gaps - exact).max() < 1e-10 * np.abs(exact).max()
    # the FE at the old bodies is the gap itself: nothing to carry
    assert np.abs(continued_gaps(ref, radius, free, np.arange(0), motion, everywhere,
                                 motion)).max() < 1e-15
    # a band of new bodies along x = max takes 0 and pulls the gap down towards it
    band = free[grid[free, 0] == n - 2]
    rest = free[grid[free, 0] < n - 2]
    g = continued_gaps(ref, radius, rest, band, motion, everywhere, zero)
    known = np.abs(np.hstack(motion(old))).max(axis=0)       # the maximum principle
    assert (np.abs(g).max(axis=0) <= known * (1 + 1e-12)).all()
    next_to_band = grid[rest, 0] == n - 3
    assert (np.abs(g[next_to_band]).mean(axis=0)
            < np.abs(exact[grid[free, 0] == n - 3]).mean(axis=0)).all()
    uncovered = continued_gaps(ref, radius, free, np.arange(0), motion,
                               lambda j: np.zeros(len(j), bool), zero)
    assert np.abs(uncovered).max() < 1e-12


@pytest.mark.slow
def test_the_slab_grows_its_zone_during_the_run(tmp_path, capsys):
    """`slab --zone grow` end to end: its indicators convert cells during the run (which one
    trips first, FE damage or a broken band link, is the physics', not the test's), the run
    goes on to its end with the sensors continuous across the conversion, and records it;
    a zone that cannot grow stops with one line and keeps what it wrote."""
    import json
    from cli.main import main
    from orchestrator.run.outputs import read_sensors
    grow = ["slab", "--model", "coupled", "--scale", "small", "--impactor-speed", "40",
            "--zone", "grow", "--zone-start", "0.5", "--layers", "1", "--fe-material", "damage",
            "--links-every", "100", "--steps", "300", "--zone-cost", "0", "--quiet"]
    # (no budget: in a 300-step run a conversion, counted as 100 steps, is what costs)
    out = tmp_path / "grow"
    assert main(grow + ["--trip-omega", "1", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    first = summary["zone_conversions"][0]
    assert summary["zone_outcome"] == "clean" and 0 < first["step"] < 300
    assert first["spheres_added"] > 0 and first["cells"]
    assert abs(first["energy_after"] / first["energy_before"] - 1) < 0.1
    assert summary["n_spheres"] == first["spheres"] + sum(
        c["spheres_added"] for c in summary["zone_conversions"][1:])
    t, names, h = read_sensors(out / "sensors.csv")
    z = h[:, names.index("under_impact"), 2]
    jump = np.abs(np.diff(z)).max()
    assert jump < 3 * np.abs(np.diff(z[:len(z) // 2])).max()     # no reset at a conversion
    # the FE series goes on in the grown zones' files (a zone that ends before the next
    # output frame has its mesh but no frame)
    assert (out / "zones.png").is_file() and list(out.glob("fe-zone*.xdmf"))
    assert main(grow + ["--trip-omega", "0.01", "--zone-limit", "0.6",
                        "--out", str(tmp_path / "limit")]) == 1
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith("coupling cannot pay for this impact") and "limit" in line
    assert (tmp_path / "limit" / "stopped" / "run.log").is_file()


def test_case_files_take_zone_grow_and_its_keys():
    from pathlib import Path
    from cases.kinds import load_case
    from cases.slab.casefile import spec as slab_spec
    slab_toml = Path(__file__).resolve().parents[1] / "cases" / "slab.toml"
    spec = slab_spec(load_case(slab_toml, ["slab.zone=grow", "zone.shear=true",
                                           "zone.ahead=0.5"]))
    assert (spec.zone, spec.grow_shear, spec.zone_ahead) == ("grow", True, 0.5)
    with pytest.raises(ValueError, match=r"\n  - zone.ahead = 0.0: must be in \(0, 1\]"):
        load_case(slab_toml, ["slab.zone=grow", "zone.ahead=0.0"])


def test_a_gap_at_the_old_edge_is_no_strain_of_the_new_links():
    """The old DE moved off the FE's field by a rigid offset δ before its cells convert (a gap
    the coupling would hold): the added spheres carry the gap on (continued_gaps), spreading
    it to 0 at the new band, and yet every new link's normal strain is what it is without
    the offset, the field's (fe_stretch), to round-off; spread as strain, δ = ε₀ H / 2 would
    change it by up to about half of ε₀."""
    from orchestrator.run.autozone import Tripped

    def new_link_strains(offset):
        block, grid, _ = growing_block(lattice_bulk_modulus())
        for _ in range(5):
            block.step()
        s = block.current.spheres
        s.read()
        s.pos[:] += offset
        s.write()
        block.grow(Tripped(5, "test", grid.dilate(block.zone, 2) & ~grid.dilate(block.zone, 1)))
        new = block.current
        at = {int(i): tuple(np.round(p / R, 6)) for i, p in zip(new.spheres.ids,
                                                                new.spheres.ref_pos)}
        made = new.parts.new_links
        return ({tuple(sorted((at[a], at[b]))): p.epsN
                 for (a, b), p in zip(made.ids.tolist(), made.phys)},
                block.conversions[-1]["carried"]["stretch"])

    plain, _ = new_link_strains(np.zeros(3))
    shifted, stretch = new_link_strains(np.array([0.5, 0.0, 0.0]) * EPS0 * H)
    assert plain.keys() == shifted.keys() and stretch > 0.1 * EPS0
    for key, eps in shifted.items():
        assert eps == pytest.approx(plain[key], rel=1e-9, abs=1e-9 * EPS0)


def test_a_zone_grown_in_place_is_the_scene_a_fresh_build_of_that_zone_makes():
    """The grown zone's model, built in the running scene (orchestrator.builder.
    assemble_grown: spheres added, linked, weights changed from the old β to the new), has
    the links, masses, materials and coupled spheres of the same zone's model built in a fresh
    scene: the same pairs, each link's reference length, cross-section, stiffnesses, E and G to
    the last bits (a weight changed twice rounds twice), masses and materials exactly."""
    from orchestrator.run.autozone import Tripped
    from yade_side import import_yade
    O = import_yade().Omega()
    block, grid, _ = growing_block(lattice_bulk_modulus())
    for _ in range(5):
        block.step()
    block.grow(Tripped(5, "test", grid.dilate(block.zone, 2) & ~grid.dilate(block.zone, 1)))

    def scene(model):
        """Links keyed by their ends' reference positions, and the spheres' mass, inertia and
        young, in model's scene."""
        at = {int(i): tuple(np.round(p / R, 6)) for i, p in zip(model.spheres.ids,
                                                                 model.spheres.ref_pos)}
        links = {tuple(sorted((at[i.id1], at[i.id2]))):
                 np.array([getattr(i.phys, k) for k in ("refLength", "crossSection", "kn",
                                                          "ks", "E", "G", "refPD",
                                                          "epsFracture", "isCohesive")])
                 for i in O.interactions if i.isReal}
        bodies = {at[int(i)]: (O.bodies[int(i)].state.mass, O.bodies[int(i)].state.inertia[0],
                               O.bodies[int(i)].material.young) for i in model.spheres.ids}
        return links, bodies, sorted(at[int(i)] for i in model.bridge.ids), \
            {tuple(sorted((at[a], at[b]))) for a, b in model.damage.links}

    # the new links' reference lengths are stretched to the FE field's strain (fe_stretch): by
    # the round-off of the old DE's gap to the field here, so refLength, refPD (abs: it is 0
    # on the axial links), kn and ks within that stretch and two roundings
    stretch = block.conversions[-1]["carried"]["stretch"]
    assert stretch < 1e-14
    grown = scene(block.current)
    fresh = scene(block.build(block.zone))
    assert grown[0].keys() == fresh[0].keys() and len(grown[0]) > 0
    for key, values in grown[0].items():
        assert values == pytest.approx(fresh[0][key], rel=4e-16 + 2 * stretch,
                                       abs=4 * stretch * R)
    assert grown[1] == fresh[1] and grown[2] == fresh[2]
    assert grown[3] == fresh[3] == set(fresh[0])


@pytest.mark.parametrize("dt, expect, calls", [
    (1e-6, {"fe_at_least": 2e-6}, ["bound"]),
    (2.5e-6, {"fe": 3e-6}, ["bound", "exact"]),
    (4e-6, None, ["bound", "exact"]),
])
def test_a_grown_zones_fe_step_is_checked_on_its_bound_first(dt, expect, calls):
    """A grown zone's model runs at the run's dt: the FE's step is checked on its lower bound
    (critical_dt_bound) alone where that holds dt, else on the eigensolve's, which refuses a
    dt above it; a first model (no old FE) takes the eigensolve's."""
    from orchestrator.builder import Description, _time_step

    class FE:
        nodes = np.zeros((1, 3))

        def __init__(self):
            self.calls = []

        def critical_dt_bound(self):
            self.calls.append("bound")
            return 2e-6

        def critical_dt(self, start=None):
            self.calls.append("exact")
            return 3e-6

    scene = SimpleNamespace(critical_dt=lambda beta: 1e-5, time_step=(None, ""))
    d = Description(scene=scene, dt=dt)
    fe, problems = FE(), []
    step, critical = _time_step(d, fe, np.ones(1), problems, old_fe=FE())
    assert fe.calls == calls
    if expect is None:
        assert step is None and "above the FE critical step" in problems[0]
    else:
        assert step == dt and not problems and critical == dict(expect, de=1e-5)
    first = FE()
    assert _time_step(d, first, np.ones(1), [], old_fe=None)[1]["fe"] == 3e-6
    assert first.calls == ["exact"]


def test_a_field_probe_found_again_past_the_object_takes_the_object_s_own_place(monkeypatch):
    """The probe's search runs past the object's end into the heap, where a copy of the probe
    (the temporary vector that carried it through the API) may lie: the first place, the
    object's own, is the field's. A stand-in object over a buffer holds its field at double
    5, and its setter leaves a copy at double 100 too."""
    from yade_side import memory

    class V3(tuple):
        def __new__(cls, x, y, z):
            return super().__new__(cls, (x, y, z))

    buffer = np.zeros(memory._SEARCH)

    class StandInPhys:
        @property
        def force(self):
            return V3(*buffer[5:8])

        @force.setter
        def force(self, v):
            buffer[5:8] = buffer[100:103] = v

    monkeypatch.setattr(memory, "state_address", lambda obj: buffer.ctypes.data)
    obj = StandInPhys()
    obj.force = V3(1.0, 2.0, 3.0)
    assert memory.field_offsets(obj, ["force"]) == {"force": (5, 3)}
    assert tuple(obj.force) == (1.0, 2.0, 3.0)                       # restored
