"""The band-stress study's cell rings and peak ratios (cases/slab/band_stress.py) on grids and
peaks whose answers are known."""
import numpy as np

from cases.slab.band_stress import cell_rings, ring_ratios
from orchestrator.coupling.cells import CellGrid


def test_rings_are_chebyshev_distances_from_the_zone():
    grid = CellGrid((0, 0, 0), (7, 5, 1), (7, 5, 2))
    zone = np.zeros(grid.shape, bool)
    zone[3:5, 2] = True                      # cells x 3-4, y 2
    x, y, z = np.meshgrid(np.arange(7) + 0.5, np.arange(5) + 0.5, [0.25, 0.75], indexing="ij")
    centres = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    rings = cell_rings(grid, zone, centres)
    ix, iy = np.floor(centres[:, 0]).astype(int), np.floor(centres[:, 1]).astype(int)
    dx = np.maximum(np.maximum(3 - ix, ix - 4), 0)
    dy = np.abs(iy - 2)
    assert np.array_equal(rings, np.maximum(dx, dy))
    assert rings[(ix == 0) & (iy == 0)].tolist() == [3, 3]   # both layers through the thickness


def test_ring_ratios_pair_cells_by_centre_and_skip_cold_ones():
    rng = np.random.default_rng(0)
    centres = rng.uniform(0, 1, (40, 3))
    ring = np.repeat([2, 3], 20)
    small_peak = np.linspace(0.5, 3.0, 40)
    ratio = np.where(ring == 2, 1.1, 0.9)
    large_peak = small_peak * ratio
    order = rng.permutation(40)               # the other mesh numbers its cells differently
    small = (centres[order], small_peak[order], ring[order])
    large = (centres + 1e-9, large_peak, ring)
    out = ring_ratios(small, large, floor=1.0, rings=(2, 3, 4))
    hot = np.maximum(small_peak, large_peak) >= 1.0
    assert set(out) == {2, 3}
    for k, r in ((2, 1.1), (3, 0.9)):
        n, p5, p50, p95, top = out[k]
        assert n == np.count_nonzero(hot & (ring == k))
        assert np.allclose([p5, p50, p95, top], r, rtol=1e-12)


def test_the_cells_read_lie_outside_the_band_in_ring_order():
    """The small slab's box zone, past the impact's first contact (2 mm at 40 m/s: 18 steps):
    every cell the trip reads is past the band's layers (ring > layers), the nearest next to
    the band, and each has a σ1 peak, some above zero."""
    from dataclasses import replace
    from cases.slab.band_stress import box_spec, peak_stress
    from cases.slab.spec import SlabSpec
    spec = box_spec(replace(SlabSpec(scale="small", impactor_speed=40.0), steps=30), 0.5)
    centres, peak, ring = peak_stress(spec, every=10)
    assert ring.min() == spec.layers + 1
    assert np.all(peak >= 0) and peak.max() > 0
    assert len(centres) == len(peak) == len(ring)
