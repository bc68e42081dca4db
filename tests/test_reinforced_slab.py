"""The reinforced slab's wiring (cases.slab.reinforced, cases.bar_split): bars cut at the DE
zone, a bar crossing the bridging band carries its EA and mass once (α + β = 1), the steel is
no concrete in the damage measure and the impactor reaches it only through the concrete, the
layers' refusals through the CLI, and the spec's round trip."""
import json
import math
from dataclasses import asdict

import numpy as np
import pytest

from cases.bar_split import split_at_zone
from cases.reinforcement import Bars, Layer
from cases.slab import SlabSpec, slab_bridging, slab_grid
from cases.slab.reinforced import DEFAULT_MESH, model_bars
from orchestrator.coupling.bridging import WEIGHT_FLOOR, Bridging, HalfSpaceZone

D, E_S, RHO_S = 0.012, 200e9, 7850.0
A_S = math.pi * D**2 / 4


def one_bar(start, end):
    return Bars(np.array([start], float), np.array([end], float), np.array([D]),
                np.array([E_S]), np.array([500e6]), np.array([RHO_S]), np.array([np.nan]),
                np.array([0]))


# --- where each model carries a bar ----------------------------------------------------------
def test_bars_are_cut_at_the_zone_where_the_weights_bend():
    """Small slab, full-width DE zone x in [lo, hi], band w: an x bar's DE part is the bar
    within [lo − w, hi + w] (one piece: one chain), its FE part the bar outside (lo, hi), cut
    where α and β bend (s = 0, f w, (1 − f) w, w); a y bar lies in the DE part if its depth is
    at most w, in the FE part if it is at least 0."""
    spec = SlabSpec(reinforced=True, de_zone=0.6, full_width=True, layers=3)
    grid = slab_grid(spec)
    bridging = slab_bridging(spec, grid)
    lo, hi, w, f = grid.hole_lo[0], grid.hole_hi[0], bridging.width, WEIGHT_FLOOR
    de, fe = model_bars(spec, "coupled", bridging)
    full, none = model_bars(spec, "full", bridging)
    assert none is None
    along_x = full.layer % 2 == 0
    x0, x1 = full.start[along_x, 0][0], full.end[along_x, 0][0]
    de_x, fe_x = de.axis[:, 0] == 1, fe.axis[:, 0] == 1
    assert np.allclose(de.start[de_x, 0], max(x0, lo - w), rtol=0, atol=1e-12)
    assert np.allclose(de.end[de_x, 0], min(x1, hi + w), rtol=0, atol=1e-12)
    assert de_x.sum() == along_x.sum()                  # one DE piece per x bar
    cuts = np.unique(np.round(np.concatenate([fe.start[fe_x, 0], fe.end[fe_x, 0]]), 12))
    expected = [x0, lo - w, lo - (1 - f) * w, lo - f * w, lo, hi, hi + f * w,
                hi + (1 - f) * w, hi + w, x1]
    assert cuts == pytest.approx(np.sort(expected), abs=1e-12)
    assert fe.length[fe_x].sum() == pytest.approx(along_x.sum() * (x1 - x0 - (hi - lo)))
    s = bridging.zone.depth(full.start[~along_x])
    assert (~de_x).sum() == np.count_nonzero(s <= w)
    assert (~fe_x).sum() == np.count_nonzero(s >= 0)


# --- a bar through the band: both models carry it, weighted, once ---------------------------
def test_a_bar_crossing_the_band_carries_its_ea_and_mass_once():
    """A bar along x from 0 to 3 m; DE zone x < 1, band 1 ≤ x ≤ 2 (w = 1). The DE chain
    (0 ≤ x ≤ 2, spheres 0.01 m apart) gets β in its masses and links as the builder gives them
    (yade_side.weighting), the FE trusses (x ≥ 1) α inside stiffness and mass. In the uniform
    strain ε, the chain's links carry β̄ E A ε, the trusses store ½ α (EA/L)(ε L)²: the bar's
    stiffness per length counted by both is EA ∫ (α + β) dx, and its mass ρ A ∫ (α + β) dx.
    α + β = 1 but where the weights' floor f holds one of them (s < f w, s > (1 − f) w):
    ∫ (α + β) = L + f² w. The weights bend at spheres and element nodes only: exact (the
    chain's ends carry half a spacing more mass than the bar, counted)."""
    from yade_side import import_yade
    from yade_side.bars import Bond, SteelChains
    from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene
    from yade_side.weighting import weight_links, weight_masses
    from fenicsx_side.mesh import box_mesh
    from fenicsx_side.model import ElasticModel
    from cases.slab.reinforced import DEBars, fe_bars
    O = import_yade().Omega()
    length, w = 3.0, 1.0
    bridging = Bridging(HalfSpaceZone((1.0, 0, 0), (1, 0, 0)), 4, w / 4)
    de, fe = split_at_zone(one_bar((0.0, 0.05, 0.05), (length, 0.05, 0.05)), bridging)
    exact = length + WEIGHT_FLOOR**2 * w

    reset_scene()
    chains = SteelChains(de, 0.005, Bond(5e6, 1e11), dt_floor=1e-7)
    assert chains.spacing == pytest.approx([0.01], rel=1e-12)
    beta = bridging.beta(np.array([O.bodies[i].state.pos for i in chains.ids.tolist()]))
    weight_masses(chains.ids, beta)
    cpm_engines(dt=1e-7)
    create_cohesive_links()
    weight_links(chains.ids, beta)
    part = DEBars(de, 0.005, None, bridging.beta)       # the yield check's link weights
    part.chains = chains
    weights = part.link_weights()
    strain = 1e-5
    for i in chains.ids.tolist():       # the uniform strain, then one step for the forces
        b = O.bodies[i]
        b.state.blockedDOFs = "xyzXYZ"
        b.state.pos = (b.state.pos[0] * (1 + strain), b.state.pos[1], b.state.pos[2])
    O.step()
    force = np.array([O.interactions[a, b].phys.Fn for a, b, _ in chains.links])
    de_stiffness = np.sum(force / strain * chains.spacing[0])        # Σ β̄ EA s
    de_mass = sum(O.bodies[i].state.mass for i in chains.ids.tolist()) / chains.mass_scale[0]
    assert force / (E_S * A_S * strain) == pytest.approx(weights, rel=1e-6)

    model = ElasticModel(box_mesh((0, 0, 0), (length, 0.1, 0.1), (6, 1, 1)), 31e9, 0.2, 2400.0)
    embedded = fe_bars(model, fe, 0.1, bridging.alpha)
    u = np.zeros(model.ndof)
    u[0::3] = strain * model.nodes[:, 0]
    fe_stiffness = u @ (embedded.stiffness @ u) / strain**2           # Σ α EA/L_e L_e²
    fe_mass = embedded.mass.sum() / 3

    assert (de_stiffness + fe_stiffness) / (E_S * A_S) == pytest.approx(exact, rel=1e-6)
    # the chain's end spheres carry a whole spacing's mass (yade_side.bars): half a spacing
    # more than the bar at each end, weighted by β there (1 and the floor)
    ends = 0.5 * chains.spacing[0] * (1.0 + WEIGHT_FLOOR)
    assert (de_mass + fe_mass) / (RHO_S * A_S) == pytest.approx(exact + ends, rel=1e-12)
    assert de_mass / (RHO_S * A_S) == pytest.approx(1.0 + 0.5 * w + 0.5 * WEIGHT_FLOOR**2 * w
                                                    + ends, rel=1e-12)


# --- the steel is no concrete --------------------------------------------------------------
def small_reinforced_block():
    """A 0.3 m cube of concrete spheres with a bar through it, bonded; and one
    free sphere (an impactor's) placed on the bar's axis beyond the block's end."""
    from yade import utils
    from yade_side import import_yade
    from yade_side.bars import Bond, SteelChains, shield_bars
    from yade_side.material import ConcreteParams, cpm_material
    from yade_side.packing import add_spheres, dense_box_packing, sphere_arrays
    from yade_side.scene import cpm_engines, create_cohesive_links, reset_scene
    O = import_yade().Omega()
    reset_scene()
    c, r = sphere_arrays(dense_box_packing((0, 0, 0), (0.3, 0.3, 0.3), 0.02))
    mat = cpm_material(ConcreteParams(density=2400.0), 0.54)
    concrete = add_spheres(c, r, mat)
    other = add_spheres(np.array([[0.3 + 0.01, 0.15, 0.15]]), np.array([0.02]), mat)
    chains = SteelChains(one_bar((0.02, 0.15, 0.15), (0.28, 0.15, 0.15)), 0.02, Bond(5e6, 1e11),
                         dt_floor=utils.PWaveTimeStep())
    shield_bars(concrete, other)
    cpm_engines(dt_safety=0.5)
    create_cohesive_links()
    chains.bond_links()
    return O, concrete, other, chains


def test_bond_and_steel_links_are_no_concrete_damage():
    """Damage = broken / initial links of the concrete spheres: links with a steel end are
    not counted. Breaking every bond link damages no concrete sphere; measured with the
    steel's links counted, it would."""
    from yade_side.damage import LinkDamage
    O, concrete, _, chains = small_reinforced_block()
    steel, mine_ids = set(chains.ids.tolist()), set(concrete.tolist())
    mine, counted = LinkDamage(concrete, exclude=chains.ids), LinkDamage(concrete)
    mine.record_initial(), counted.record_initial()
    pairs = [(i.id1, i.id2) for i in O.interactions if i.isReal and i.phys.isCohesive]
    plain = [p for p in pairs if p[0] not in steel and p[1] not in steel]
    bonds = [p for p in pairs if (p[0] in steel) != (p[1] in steel)]
    ends = sum((a in mine_ids) + (b in mine_ids) for a, b in plain)   # the concrete's ends
    assert bonds and mine.initial.sum() == ends
    assert counted.initial.sum() == ends + len(bonds)
    assert len(mine.link_omega()[1]) == sum(a in mine_ids or b in mine_ids for a, b in plain)
    for a, b in bonds:
        O.interactions.erase(a, b)
    assert np.all(mine.update() == 0) and mine.worst_link().max() < 1
    assert counted.update().max() > 0 and counted.worst_link().max() == 1


def test_the_impactor_meets_the_concrete_not_the_steel():
    """shield_bars: the free sphere overlapping the bar's last steel sphere gets no interaction
    with it; the concrete does (its bonds), and with the free sphere too."""
    O, concrete, other, chains = small_reinforced_block()
    steel = set(chains.ids.tolist())
    O.step()
    touching = {(i.id1, i.id2) for i in O.interactions if i.isReal}
    last = int(chains.ids[-1])
    gap = np.subtract(O.bodies[last].state.pos, O.bodies[int(other[0])].state.pos)
    assert np.linalg.norm(gap) < 2 * 0.02                # they overlap
    assert not any(int(other[0]) in p and (p[0] in steel or p[1] in steel) for p in touching)
    assert any(int(other[0]) in p and (p[0] in set(concrete.tolist()) or
                                      p[1] in set(concrete.tolist())) for p in touching)


# --- the layers: default mesh, case files, the CLI ------------------------------------------
def test_the_default_mesh_is_two_way_at_both_faces():
    """12 mm at 150 mm, x bars outside (axes 36 mm from the faces: 30 mm cover), y bars on
    them (48 mm), top and bottom; 754 mm²/m per direction and face."""
    spec = SlabSpec(reinforced=True)
    assert spec.reinforcement == DEFAULT_MESH and len(DEFAULT_MESH) == 4
    assert [(l.face, l.direction, round(l.cover, 9)) for l in DEFAULT_MESH] == [
        ("bottom", "x", 0.036), ("bottom", "y", 0.048), ("top", "x", 0.036), ("top", "y", 0.048)]
    assert all(l.cover - l.diameter / 2 >= 0.030 - 1e-12 for l in DEFAULT_MESH)
    assert A_S / 0.15 == pytest.approx(754e-6, rel=1e-3)
    assert SlabSpec().reinforcement == () and not SlabSpec().reinforced


def test_the_spec_round_trips_through_the_summary():
    """summary.json's spec (asdict through JSON) gives the same slab, bars included."""
    for spec in (SlabSpec(reinforced=True),
                 SlabSpec(reinforcement=[dict(diameter=0.016, spacing=0.2, direction="y",
                                              cover=0.05, face="top", bond_strength=8e6)])):
        back = SlabSpec(**json.loads(json.dumps(asdict(spec))))
        assert back.reinforced and back.reinforcement == spec.reinforcement
        assert asdict(back) == asdict(spec)


CASE = """[case]
kind = "slab"
[slab]
model = "full"
{slab}
[[reinforcement]]
diameter = 0.012
direction = "x"
{layer}
"""


def write_case(tmp_path, layer, slab=""):
    path = tmp_path / "slab.toml"
    path.write_text(CASE.format(layer=layer, slab=slab))
    return path


def test_a_case_files_layers_reach_the_slab(tmp_path):
    from cases.kinds import load_case
    from cases.slab.casefile import spec
    case = load_case(write_case(tmp_path, "spacing = 0.2\ncover = 0.04\nface = \"top\"",
                                "reinforced = false"))
    s = spec(case)
    assert s.reinforced and s.reinforcement == (Layer(0.012, 0.2, "x", 0.04, face="top"),)


@pytest.mark.parametrize("layer, message", [
    ("spacing = 0.15\ncover = 0.005",
     "reinforcement[0].cover = 0.005 m is below the bar radius 0.006 m"),
    ("spacing = 0.15\ncover = 0.3", "reinforcement[0].cover = 0.3 m puts the bars outside the "
                                    "concrete: it is 0.28 m thick"),
    ("spacing = 0.0\ncover = 0.04", "reinforcement[0].spacing = 0.0: must be in (0, 1] m"),
    ("spacing = 0.15\ncover = 0.04\nface = \"side\"", "reinforcement[0].face = 'side': expected "
                                                      "one of 'bottom', 'top'"),
    ("cover = 0.04", "reinforcement[0].spacing: missing (required)"),
    ("spacing = 0.15\ncover = 0.04\nspacin = 1", "reinforcement[0].spacin: unknown key"),
    ("spacing = 0.15\ncover = 0.04\n[[reinforcement]]\ndiameter = 0.012\ndirection = \"y\"\n"
     "spacing = 0.15\ncover = 0.052\nbond_strength = 5e6",
     "reinforcement[1].bond_strength = 5000000.0: every layer must have the same bond strength"),
])
def test_bad_layers_in_a_case_file_are_refused_by_the_cli(tmp_path, capsys, layer, message):
    from test_faults import cli, one_line_error
    path = write_case(tmp_path, layer)
    code = cli(["run", str(path), "--out", str(tmp_path / "out")])
    err = one_line_error(capsys, code)
    assert f"case file {path}" in err and message in err
    assert not (tmp_path / "out").exists()


def test_reinforced_is_a_slab_option(tmp_path, capsys):
    """`slab --reinforced` sets the field; the option refuses a value."""
    import argparse
    from cli.commands import slab as command
    from cli.commands._options import spec_from_args
    p = argparse.ArgumentParser()
    command.configure(p)
    args = p.parse_args(["--model", "full", "--out", str(tmp_path / "o"), "--reinforced"])
    assert spec_from_args(SlabSpec, args).reinforcement == DEFAULT_MESH
    args = p.parse_args(["--model", "full", "--out", str(tmp_path / "o"), "--no-reinforced"])
    assert not spec_from_args(SlabSpec, args).reinforced
    from test_faults import cli
    assert cli(["slab", "--model", "full", "--reinforced=1", "--out", str(tmp_path / "o")]) == 2
    assert "Traceback" not in capsys.readouterr().err
