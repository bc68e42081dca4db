"""The slab with a graded FE mesh (`band_ratio`): the band's cells of band_ratio sphere
diameters, growing to the grid's size away from the zone. Exact geometry of the FE part
against the zone and its band, the sensors on the graded grid, the thinner band's spheres,
a short stable run, and the refusals."""
import numpy as np
import pytest
import ufl
from dolfinx import fem

from cases.slab import SlabModel, SlabSpec
from cases.slab.zone import GROWTH, fe_axes, slab_grid
from cases.slab.scales import SLAB

# the small slab's full-width strip with three layers, the geometry these figures are for
STRIP = dict(de_zone=0.6, full_width=True, layers=3)


@pytest.fixture(scope="module")
def models():
    """Built only (the YADE scene is the last one's): their geometry, FE parts and sensors."""
    return {br: SlabModel(SlabSpec(scale="small", band_ratio=br, steps=60, **STRIP), "coupled")
            for br in (None, 2.0)}


def test_graded_grid_band_cells_growth_and_planes():
    """Small scale: grid h = 1/6 m, band cells 2 × 2 × 0.025 = 0.1 m; along x three of them on
    each side of the zone (0.833-1.667 m) end on grid planes, then cells grow by ≤ 1.2 to ≤ h;
    y (the zone spans the width) stays uniform."""
    spec = SlabSpec(scale="small", band_ratio=2.0, **STRIP)
    g = slab_grid(spec)
    xs, ys, zs = fe_axes(g)
    assert g.band_h == pytest.approx(0.1, rel=1e-15) and g.axes == (0,)
    lo, hi = g.hole_lo[0], g.hole_hi[0]
    for k in range(4):
        for plane in (lo - k * 0.1, hi + k * 0.1):
            assert np.abs(xs - plane).min() < 1e-12
    dx = np.diff(xs)
    assert dx.max() <= g.h * (1 + 1e-12)
    assert np.all(dx[1:] / dx[:-1] <= GROWTH * (1 + 1e-9))
    assert np.all(dx[:-1] / dx[1:] <= GROWTH * (1 + 1e-9))
    assert np.allclose(ys, np.linspace(0, SLAB[1], g.n[1] + 1), rtol=0, atol=0)
    assert xs[0] == 0.0 and xs[-1] == SLAB[0]


def test_graded_band_fits_by_its_own_cells_not_the_grid_s():
    """Small scale, the 0.5 m box: y holds 12 cells of 1/6 m, the zone 4 (centred), 4 on each
    side of it. Four layers of 1/6 m and one FE cell do not fit in those 2/3 m; four layers of
    1.5 × 0.05 = 0.075 m (0.3 m) and one more do: their planes, then cells growing to ≤ h."""
    with pytest.raises(ValueError, match="do not fit"):
        slab_grid(SlabSpec(scale="small", layers=4))
    g = slab_grid(SlabSpec(scale="small", layers=4, band_ratio=1.5))
    assert g.band_h == pytest.approx(0.075, rel=1e-15) and g.hole_lo[1] == pytest.approx(4 / 6)
    ys = fe_axes(g)[1]
    for k in range(5):
        assert np.abs(ys - (g.hole_lo[1] - 0.075 * k)).min() < 1e-12
    assert ys[0] == 0.0 and np.diff(ys).max() <= g.h * (1 + 1e-12)
    with pytest.raises(ValueError, match="do not fit"):     # 8 layers and one: 0.675 m
        slab_grid(SlabSpec(scale="small", layers=8, band_ratio=1.5))


def test_graded_fe_part_is_the_slab_less_the_zone_and_its_nodes_the_grid(models):
    m = models[2.0]
    g = m.grid
    volume = fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=m.fe.msh)))
    assert volume == pytest.approx(np.prod(SLAB) - np.prod(g.hole_hi - g.hole_lo), rel=1e-13)
    xs, ys, zs = fe_axes(g)
    nodes = m.fe.nodes
    for axis, planes in enumerate((xs, ys, zs)):
        assert np.abs(nodes[:, axis, None] - planes[None, :]).min(axis=1).max() < 1e-12
    inside = np.all((nodes > g.hole_lo + 1e-9) & (nodes < g.hole_hi - 1e-9), axis=1)
    assert not inside.any()


def test_thinner_band_keeps_fewer_spheres_all_within_its_width(models):
    """The band is 3 × 0.1 m instead of 3 × 1/6 m: the bridging spheres are those within
    0.3 m of the zone, fewer than the uniform mesh's; the zone's own spheres are the same."""
    uniform, graded = models[None], models[2.0]
    depth = graded.bridging.zone.depth(graded.spheres.ref_pos)
    band = depth > 0
    assert np.array_equal(np.flatnonzero(band), np.sort(graded.bridge_index))
    assert depth.max() <= 0.3 + 1e-12
    assert len(graded.bridge_index) < len(uniform.bridge_index)
    u_depth = uniform.bridging.zone.depth(uniform.spheres.ref_pos)
    assert np.count_nonzero(depth <= 0) == np.count_nonzero(u_depth <= 0)


def test_sensors_sit_on_the_graded_grid(models):
    m = models[2.0]
    g = m.grid
    xs, ys, zs = fe_axes(g)
    node = m.fe.nodes[m._sensor_nodes[0]]
    for axis, planes in enumerate((xs, ys, zs)):
        assert np.abs(planes - node[axis]).min() < 1e-12
    bridging = m.sensor_positions[list(m.sensor_names).index("bridging")]
    assert abs(bridging[0] - (g.hole_hi[0] + 0.15)) < 2 * m.spec.radius


def test_before_the_wave_reaches_the_band_graded_and_uniform_runs_agree(tmp_path):
    """30 steps of 0.3 × the critical step (0.085 ms): the impact's wave (≤ 3.4 km/s) travels
    ≤ 0.29 m, short of the band 0.42 m from the impact: the DE zone's spheres are the same in
    both models, so the energies and the sensor under the impactor agree to round-off."""
    from cases.slab.model import run_built
    runs = {}
    for br in (None, 2.0):               # one YADE scene per process: build, then run
        m = SlabModel(SlabSpec(scale="small", band_ratio=br, dt_safety=0.3, steps=30,
                              **STRIP), "coupled")
        (tmp_path / str(br)).mkdir()
        runs[br] = run_built(m, tmp_path / str(br), quiet=True)
    e = {br: np.array(r["energy"])[:, 1] for br, r in runs.items()}
    assert np.all(np.isfinite(e[2.0]))
    assert np.abs(e[2.0] - e[None]).max() < 1e-9 * e[None][0]
    peak = {br: r["sensors"]["under_impact"]["peak_displacement"] for br, r in runs.items()}
    assert peak[2.0] == pytest.approx(peak[None], rel=1e-9)


@pytest.mark.parametrize("options, message", [
    (dict(band_ratio=4.0), r"^slab: band_ratio = 4.0 must not exceed fe_ratio = 3.0"),
    (dict(band_ratio=2.0, zone="auto"), r"^slab: band_ratio \(a graded FE mesh\) applies to box"),
    (dict(band_ratio=-1.0), r"^slab: band_ratio must be"),
])
def test_bad_band_ratio_is_refused_in_one_line(options, message):
    with pytest.raises(ValueError, match=message) as e:
        SlabSpec(**options)
    assert "\n" not in str(e.value)
