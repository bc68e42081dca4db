"""Case files: every problem is reported before anything runs, one line each, naming the key
and the value; good files load with their defaults."""
import re
from pathlib import Path

import pytest

from cases.kinds import load_case as load
from orchestrator.casefile import CaseError

ROOT = Path(__file__).resolve().parents[1]
BLOCK = ROOT / "cases" / "block_impact.toml"


def write(tmp_path, text, name="c.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


GOOD = """
[de]
[[de.packing]]
lo = [0.3, 0.3, 0.0]
hi = [0.9, 0.9, 0.12]
radius = 0.02
[fe]
lo = [0.0, 0.0, 0.0]
hi = [1.2, 1.2, 0.12]
n = [20, 20, 2]
[coupling]
zone_lo = [0.42, 0.42, 0.0]
zone_hi = [0.78, 0.78, 0.12]
[time]
steps = 10
"""


def test_a_minimal_case_gets_its_defaults(tmp_path):
    case = load(write(tmp_path, GOOD, "plate.toml"))
    assert case.kind == "generic" and case["case"]["name"] == "plate"
    cp = case["coupling"]
    assert (cp["layers"], cp["variant"], cp["relaxation"], cp["rotations"]) == (3, "diagonal", "auto", True)
    assert cp["zone_axes"] == [0, 1]
    assert cp["element_size"] == pytest.approx(0.06, rel=1e-12)   # the box's element size
    assert case["time"]["dt_safety"] == 0.3
    assert case["de"]["packing"][0]["velocity"] == [0.0, 0.0, 0.0]
    assert case["material"]["young"] == 31e9 and case["material"]["cpm"] == {}


def test_every_problem_is_listed_with_its_key_and_value(tmp_path):
    text = GOOD.replace("[time]\nsteps = 10", """[time]
steps = 10
dt_safety = 1.5
[output]
every = "often"
""").replace("[coupling]", "[coupling]\nlayers = 0\nrelaxation = -2.0\ncolour = 1")
    with pytest.raises(CaseError) as e:
        load(write(tmp_path, text))
    problems = e.value.problems
    assert problems == [
        "coupling.colour: unknown key (known here: element_size, layers, relaxation, rotations, "
        "variant, weighting, zone_axes, zone_hi, zone_lo)",
        "coupling.layers = 0: must be in [1, 1000]",
        "coupling.relaxation = -2.0: must be in (0, 1e+06]",
        "time.dt_safety = 1.5: must be in [0.001, 1] (× the critical step)",
        "output.every = 'often': expected an integer",
    ]
    assert str(e.value).count("\n  - ") == len(problems)


@pytest.mark.parametrize("change, message", [
    (("radius = 0.02", "radius = 0"), "de.packing[0].radius = 0: must be in (0, 1] m"),
    (("radius = 0.02", "radius = true"), "de.packing[0].radius = True: expected a finite number"),
    (("n = [20, 20, 2]", "n = [20, 20]"), "fe.n = [20, 20]: expected a list of 3 positive integers"),
    (("zone_lo = [0.42, 0.42, 0.0]", "zone_lo = [-0.12, 0.42, 0.0]"),
     "coupling.zone_lo[0] = -0.12: the DE zone is outside the mesh, which spans [0.0, 1.2] along axis 0"),
    (("zone_hi = [0.78, 0.78, 0.12]", "zone_hi = [0.78, 0.75, 0.12]"),
     "coupling.zone_hi[1] = 0.75: not on a grid plane of the box mesh (nearest: 0.72, 0.78)"),
    (("steps = 10", "steps = 10\nduration = 1e-3"), "time: give either time.duration (s) or time.steps, not both"),
    (("[de]", "[de]\nscript = 'nope.py'"), "de: give either de.script"),
    (("[coupling]", "[coupling]\nvariant = 'half'"), "coupling.variant = 'half': expected one of 'full', 'diagonal'"),
    (("[coupling]", "[coupling]\nrelaxation = 'big'"), "coupling.relaxation = 'big': expected a number, \"auto\" or \"rho\""),
])
def test_single_problems(tmp_path, change, message):
    with pytest.raises(CaseError, match=re.escape(message)):
        load(write(tmp_path, GOOD.replace(*change)))


def test_sensors_and_gmsh_consistency(tmp_path):
    text = GOOD.replace("[fe]\nlo = [0.0, 0.0, 0.0]\nhi = [1.2, 1.2, 0.12]\nn = [20, 20, 2]",
                        "[fe]\nmesh = 'plate.msh'") + """
[[sensors]]
name = "a"
[[sensors]]
name = "b"
sphere = 3
on = "fe"
[[sensors]]
name = "b"
point = [0, 0, 0]
"""
    with pytest.raises(CaseError) as e:
        load(write(tmp_path, text))
    assert e.value.problems == [
        "sensors[0] ('a'): give either point or sphere",
        "sensors[1].on = 'fe': a sphere sensor is on the DE side",
        "sensors: two sensors are named 'b'",
        f"fe.mesh = 'plate.msh': file {tmp_path / 'plate.msh'} not found",
        "coupling.element_size: required with a gmsh mesh (the bridging width is layers × element_size)",
    ]


def test_overrides_are_checked_like_the_file(tmp_path):
    path = write(tmp_path, GOOD)
    case = load(path, ["coupling.relaxation=12.5", "coupling.variant=full", "case.name=x"])
    assert case["coupling"]["relaxation"] == 12.5 and case["coupling"]["variant"] == "full"
    assert case["case"]["name"] == "x"
    with pytest.raises(CaseError, match=re.escape("coupling.r: unknown key")):
        load(path, ["coupling.r=3"])
    with pytest.raises(CaseError, match=re.escape("--set 'layers': expected dotted.key=value")):
        load(path, ["layers"])


def test_shipped_case_files_load():
    block = load(BLOCK)
    assert block["de"]["script"] == str(ROOT / "cases" / "scripts" / "block_impact.py")
    slab = load(ROOT / "cases" / "slab.toml")
    assert slab.kind == "slab"


def test_the_slab_case_file_is_the_slab_commands_default():
    from cases.slab import SlabSpec
    from cases.slab.casefile import spec as slab_spec
    spec = slab_spec(load(ROOT / "cases" / "slab.toml"))
    assert spec == SlabSpec(scale="small", variant="diagonal", relaxation="rho", rotations=True,
                            output_every=200)


def test_a_full_slab_case_takes_the_box_zone_and_refuses_one_the_coupled_model_finds():
    from cases.slab.casefile import spec as slab_spec
    case = ROOT / "cases" / "slab.toml"
    assert slab_spec(load(case)).zone == "grow"
    assert slab_spec(load(case, ["slab.model=full", "slab.zone=box"])).zone == "box"
    with pytest.raises(CaseError) as e:
        load(case, ["slab.model=full"])        # the shipped file's zone = "grow"
    assert e.value.problems == ["slab.zone = grow finds the DE zone of a coupled model: the "
                                "full model has none (run it as the coupled model)"]


def test_the_wave1d_case_file_holds_the_wave1d_commands_defaults():
    """Both are Wave1DSpec's defaults: the command's options and the case file's keys are
    its fields."""
    from cases.wave1d import Wave1DSpec
    from orchestrator.casefile import spec_from_case
    from cli.main import build_parser
    from cli.commands._options import spec_from_args
    args = build_parser().parse_args(["wave1d", "--out", "x"])
    case = load(ROOT / "cases" / "wave1d.toml")
    assert spec_from_case(Wave1DSpec, case.data) == spec_from_args(Wave1DSpec, args) \
        == Wave1DSpec()
