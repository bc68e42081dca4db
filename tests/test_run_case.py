"""`python3 -m cli run CASE.toml` on the shipped user-script case: the results folder
reads back, the coupling step inserted in YADE's engine list is exact, and the checks that
need both models stop a bad case before its first step."""
import json
import re
import textwrap
from pathlib import Path

import meshio
import numpy as np
import pytest

from cases.generic import CaseModel
from cases.kinds import load_case as load
from cases.slab import SlabSpec
from orchestrator.casefile import CaseError
from cli.main import main
from yade_side.output import read_series

ROOT = Path(__file__).resolve().parents[1]
BLOCK = ROOT / "cases" / "block_impact.toml"
EPS = np.finfo(float).eps
ROTATIONS_OFF = ["coupling.rotations=false"]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("block") / "run"
    assert main(["run", str(BLOCK), "--set", "time.duration=1.2e-4", "--set", "output.every=25",
                 "--out", str(out), "--quiet"]) == 0
    return out


def test_the_results_folder_holds_everything_and_reads_back(run_dir):
    for name in ("case.toml", "summary.json", "run.log", "sensors.csv", "damage.npz",
                 "spheres.pvd", "fe.xdmf", "fe/mesh.h5", "sensors.png", "damage.png"):
        assert (run_dir / name).stat().st_size > 0, name
    s = json.loads((run_dir / "summary.json").read_text())
    assert s["steps"] == int(np.ceil(1.2e-4 / s["dt"]))
    assert s["dt"] <= min(s["critical_dt"].values())
    assert set(s["sensors"]) == {"under_impact", "bridging", "fe_plate"}
    assert any("damping was 0.2" in n for n in s["notes"])
    assert s["relaxation"] > 1 and s["n_bridging_spheres"] > 0
    frames = read_series(run_dir / "spheres.pvd")
    assert [t for t, _ in frames][0] == 0.0 and len(frames) == 1 + int(np.ceil(s["steps"] / 25))
    last = frames[-1][1]
    assert len(last.points) == s["n_spheres"]
    assert last.point_data["displacement"].shape == (s["n_spheres"], 3)
    assert np.all((last.point_data["damage"] >= 0) & (last.point_data["damage"] <= 1))
    # the spheres moved: the displacement field is the change of the written centres
    assert np.allclose(last.points - frames[0][1].points, last.point_data["displacement"],
                       rtol=0, atol=1e-12)
    with meshio.xdmf.TimeSeriesReader(run_dir / "fe.xdmf") as reader:
        points, _ = reader.read_points_cells()
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    assert len(steps) == len(frames)
    assert steps[-1][1]["displacement"].shape == (len(points), 3) == (s["n_fe_nodes"], 3)
    # the log has the set-up, the checks and the end; the case file copy runs again as is
    text = (run_dir / "run.log").read_text()
    assert "note: block_impact.py: NewtonIntegrator damping" in text and "done:" in text
    again = load(run_dir / "case.toml")
    assert again["time"]["duration"] == 1.2e-4 and again["de"]["script"] == str(
        ROOT / "cases" / "scripts" / "block_impact.py")


def test_a_run_never_overwrites_an_earlier_one(run_dir, capsys):
    before = (run_dir / "summary.json").read_text()
    assert main(["run", str(BLOCK), "--out", str(run_dir), "--quiet"]) == 2
    assert "--force" in capsys.readouterr().err
    assert (run_dir / "summary.json").read_text() == before


def test_full_lagrange_in_the_engine_list_holds_the_constraints_every_step():
    """Full multipliers, r = 1: after every O.step() (the coupling runs inside it, right after
    NewtonIntegrator) the bridging spheres' YADE state satisfies d = k u and ω = h u to
    round-off, with the bridging spheres set moving."""
    case = load(BLOCK, ["coupling.variant=full", "coupling.relaxation=1.0"])
    m = CaseModel(case)
    rng = np.random.default_rng(3)
    m.bridge.set_velocity(rng.normal(size=(len(m.bridge), 3)), rng.normal(size=(len(m.bridge), 3)))
    worst = 0.0
    for n in range(1, 31):
        m.step()
        c = m.stepper.last
        assert m.stepper.steps == n                      # one coupling per O.step()
        m.bridge.read()
        d = m.bridge.displacement().ravel()
        # d = position − reference: round-off of the positions (~0.6 m), not of d
        assert np.allclose(d, c.q[:d.size], rtol=0, atol=4 * EPS * np.abs(m.bridge.pos).max())
        worst = max(worst, np.abs(c.q - c.Gu).max() / np.abs(c.q).max())
    assert np.abs(m.bridge.displacement()).max() > 1e-6    # they moved, far beyond round-off
    assert worst < 1e-12


def test_problems_needing_both_models_stop_the_case_before_it_runs(tmp_path, capsys):
    out = tmp_path / "bad"
    code = main(["run", str(BLOCK), "--set", "time.dt=1e-5", "--set", "fe.hi=[1.2, 1.2, 0.06]",
                 "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert re.search(r"time\.dt = 1e-05 s: above the DE critical step 4\.\d+e-06 s", err)
    assert re.search(r"coupling: bridging spheres in no FE element: point \d+ at .* is in no FE "
                     r"cell \(\d+ of \d+ points are outside the mesh\)", err)
    assert main(["run", str(BLOCK), "--set", "fe.lo=[0.0, 0.0, 0.2]", "--set",
                 "fe.hi=[1.2, 1.2, 0.32]", "--out", str(out), "--quiet"]) == 2
    # every bridging sphere outside the mesh: the first is named, all are counted
    assert re.search(r"bridging spheres in no FE element: point 0 at .* \((\d+) of \1 points are "
                     r"outside the mesh\)", capsys.readouterr().err)


def write_plate_msh(folder, hole=True):
    """The block case's plate (1.2 × 1.2 × 0.12 m, 20 × 20 × 2 hexahedra) as a gmsh file, with
    the DE zone [0.42, 0.78]² cut out, and a case file using it."""
    x, y, z = np.meshgrid(np.linspace(0, 1.2, 21), np.linspace(0, 1.2, 21), np.linspace(0, 0.12, 3),
                          indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    node = lambda i, j, k: (i * 21 + j) * 3 + k
    cells = [[node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k),
              node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)]
             for i in range(20) for j in range(20) for k in range(2)
             if not (hole and 7 <= i < 13 and 7 <= j < 13)]
    meshio.write(folder / "plate.msh", meshio.Mesh(points, [("hexahedron", np.array(cells))]),
                 file_format="gmsh22", binary=False)
    text = BLOCK.read_text().replace('mesh = "box"\nlo = [0.0, 0.0, 0.0]\nhi = [1.2, 1.2, 0.12]\n'
                                     'n = [20, 20, 2]', 'mesh = "plate.msh"')
    text = text.replace('script = "scripts/', f'script = "{ROOT}/cases/scripts/')
    text = text.replace("layers = 2", "layers = 2\nelement_size = 0.06")
    (folder / "gmsh.toml").write_text(text)
    return folder / "gmsh.toml"


def test_a_gmsh_mesh_gives_the_same_run_as_the_box_it_meshes(tmp_path):
    """The block case on a gmsh file of the same holed plate (read with meshio): same nodes,
    same mass, and the same sensor histories (bridging spheres set moving) to round-off.
    Translations only: the script's regular packing puts sphere centres on element faces,
    where the rotation operator h (a gradient) jumps and either cell is a valid choice."""
    gmsh = write_plate_msh(tmp_path)
    histories, masses = [], []
    for case in (load(BLOCK, ROTATIONS_OFF), load(gmsh, ROTATIONS_OFF)):
        m = CaseModel(case)
        masses.append((len(m.fe.nodes), m.fe.mass.sum()))
        m.bridge.set_velocity(np.random.default_rng(5).normal(size=(len(m.bridge), 3)))
        h = []
        for _ in range(40):
            m.step()
            h.append(m.sensor_displacements())
        histories.append(np.array(h))
        size = np.abs(m.spheres.ref_pos).max()
    assert masses[0][0] == masses[1][0] and np.isclose(masses[0][1], masses[1][1], rtol=1e-13)
    # displacement = position − reference: its round-off is that of the positions (~0.6 m),
    # whatever the displacement's own size; the two meshes number their nodes differently
    scale = np.abs(histories[0]).max()
    assert scale > 1e6 * EPS * size
    assert np.allclose(histories[0], histories[1], rtol=0, atol=8 * EPS * size)


def test_a_gmsh_mesh_must_hold_the_de_zone_and_leave_it_out(tmp_path):
    with pytest.raises(CaseError, match=re.escape(
            "coupling.zone_lo[0] = -0.3: the DE zone is outside the mesh, which spans [0, 1.2] "
            "along axis 0")):
        CaseModel(load(write_plate_msh(tmp_path), ["coupling.zone_lo=[-0.3, 0.42, 0.0]"]))
    with pytest.raises(CaseError, match=re.escape(
            "fe.mesh: 72 elements lie inside the DE zone; the FE mesh must leave the DE zone out")):
        CaseModel(load(write_plate_msh(tmp_path, hole=False)))


SMALL = """
[de]
script = "{script}"
[fe]
lo = [0.0, 0.0, 0.0]
hi = [0.6, 0.6, 0.1]
n = [6, 6, 1]
[coupling]
zone_lo = [0.2, 0.2, 0.0]
zone_hi = [0.4, 0.4, 0.1]
layers = 1
[time]
steps = 1
"""
SPHERES = """
from yade import pack
O.bodies.append(pack.regularHexa(pack.inAlignedBox((0.1, 0.1, 0), (0.5, 0.5, 0.1)), radius=0.02, gap=0.001))
O.engines = [ForceResetter(), InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
             InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                             [Law2_ScGeom_FrictPhys_CundallStrack()]),
             NewtonIntegrator(damping=0)]
"""


@pytest.mark.parametrize("extra, reason", [
    ("O.bodies.appendClumped([sphere((0.45, 0.3, 0.2), 0.02), sphere((0.45, 0.33, 0.2), 0.02)])",
     "3 bodies in the bridging domain are clumps or clump members"),  # clump + 2 members
    ("O.bodies.append(box((0.45, 0.3, 0.3), (0.02, 0.02, 0.02)))",
     "1 bodies in the bridging domain are not spheres"),
    ("O.bodies.append(sphere((0.45, 0.3, 0.3), 0.02, fixed=True))",
     "1 bodies in the bridging domain are not dynamic"),
])
def test_what_cannot_be_coupled_is_refused_with_a_reason(tmp_path, extra, reason):
    from yade_side.user_script import ScriptRefused
    script = tmp_path / "s.py"
    script.write_text(SPHERES + extra + "\n")
    case = tmp_path / "c.toml"
    case.write_text(SMALL.format(script=script))
    with pytest.raises(ScriptRefused, match=re.escape(reason)):
        CaseModel(load(case))


@pytest.mark.slow
def test_built_in_packing_case_before_contact():
    """cases/plate_impact.toml (randomDensePack, memoized): before contact the impactor flies
    rigidly at its initial velocity (its internal forces cancel), the plate and the FE model
    stay exactly at rest; then the impact reaches the FE model."""
    m = CaseModel(load(ROOT / "cases" / "plate_impact.toml"))
    impactor = m.spheres.ref_pos[:, 2] > 0.2
    assert impactor.any() and m.bridge_index.size > 0
    for _ in range(100):
        m.step()
    m.spheres.read()
    v = m.spheres.vel
    assert np.allclose(v[impactor], [0, 0, -40], rtol=0, atol=1e-12 * 40)
    assert not v[~impactor].any() and not m.fe.u.any()
    for _ in range(400):
        m.step()
    assert np.abs(m.fe.u).max() > 0 and np.isfinite(m.energy())


def test_the_wave1d_case_file_runs_the_wave1d_command_with_its_keys(tmp_path):
    out = tmp_path / "w"
    assert main(["run", str(ROOT / "cases" / "wave1d.toml"), "--set", "coupling.layers=2",
                 "--out", str(out), "--quiet"]) == 0
    parameters = json.loads((out / "summary.json").read_text())["parameters"]
    assert parameters["layers"] == 2 and parameters["variant"] == "diagonal"
    assert load(out / "case.toml")["coupling"]["layers"] == 2


def test_a_script_that_never_steps_gets_its_links_counted_after_the_first_step(tmp_path):
    """Damage needs the initial cohesive links: a script that leaves O.iter at 0 makes them in
    the first coupled step, and they are recorded then (none broken yet)."""
    script = tmp_path / "cpm.py"
    script.write_text(textwrap.dedent("""
        from yade import pack
        mat = O.materials.append(CpmMat(young=30e9, density=4000, sigmaT=3e6, epsCrackOnset=1e-4,
                                        relDuctility=30, frictionAngle=0.6))
        O.bodies.append(pack.regularHexa(pack.inAlignedBox((0.1, 0.1, 0), (0.5, 0.5, 0.1)),
                                         radius=0.02, gap=0, material=mat))
        O.engines = [ForceResetter(),
                     InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=1.5)]),
                     InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=1.5)],
                                     [Ip2_CpmMat_CpmMat_CpmPhys()], [Law2_ScGeom_CpmPhys_Cpm()]),
                     NewtonIntegrator(damping=0)]
    """))
    case = tmp_path / "c.toml"
    case.write_text(SMALL.format(script=script))
    m = CaseModel(load(case))
    assert m.O.iter == 0 and m.damage.initial.sum() == 0
    m.step()
    assert m.damage.initial.sum() > 0 and not m.damage.update().any()


@pytest.mark.slow
def test_the_slab_case_file_runs_the_slab(tmp_path):
    out = tmp_path / "slab"
    assert main(["run", str(ROOT / "cases" / "slab.toml"), "--set", "time.steps=30",
                 "--set", "output.every=15", "--out", str(out), "--quiet"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["model"] == "coupled" and s["steps"] == 30
    assert s["spec"]["relaxation"] == SlabSpec().relaxation == "rho"
    assert s["coupling"]["relaxation"] == s["coupling"]["lumping_ratio"]
    for name in ("case.toml", "run.log", "spheres.pvd", "fe.xdmf", "sensors.png", "damage.png"):
        assert (out / name).is_file(), name
