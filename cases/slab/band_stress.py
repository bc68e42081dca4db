"""Does the coupling raise the elastic FE's stress next to the bridging band?
`python3 -m cases.slab.band_stress --scale medium --impactor-speed 20 --seed 1 --zones 0.5,0.9`.

The grown zone's elastic FE trips on its cells' largest principal stress σ1 outside the band
(orchestrator/run/autozone.py), and most trips come in the first cells outside it
(docs/auto-zone.md). The same impact is run with fixed box zones of two sides, the FE
elastic; every `--every` steps σ1 is read in the cells the trip reads, and each cell keeps its
peak. A cell in the first ring outside the larger zone's band lies farther out in the smaller
zone's run: if the coupling raised the stress next to the band, its peak would be higher in
the larger zone's run than in the smaller's. Per ring of the larger zone (the Chebyshev
distance in in-plane cells from its zone; ring layers + 1 is the first outside its band), the
ratio of the two peaks over the cells that reach ft in either run.
"""
import argparse
from dataclasses import replace

import numpy as np
from scipy.ndimage import distance_transform_cdt

from cases.slab.spec import SlabSpec
from cases.slab.zone import cell_grid, slab_grid

KEY_DIGITS = 6   # cell centres are matched between the two meshes of one grid to 1 µm
HOTTEST = 6      # cells printed per run


def cell_rings(grid, zone_mask, centres):
    """The Chebyshev distance, in in-plane cells of `grid` (a CellGrid), of the cells whose
    centres are `centres` from the zone `zone_mask`: 0 inside it, 1 next to it."""
    distance = distance_transform_cdt(~np.asarray(zone_mask, bool), metric="chessboard")
    return distance[grid.index_of(centres)]


def box_spec(spec, side):
    """`spec` with a fixed box zone of `side` m and an elastic FE (ValueError if it does not
    fit)."""
    spec = replace(spec, zone="box", de_zone=side, fe_material="elastic")
    slab_grid(spec)
    return spec


def peak_stress(spec, every):
    """Run the coupled slab of `spec` (box_spec) for its steps: (centres of the cells the trip
    reads, their peak σ1 over the run in Pa, their ring)."""
    from cases.slab.model import SlabModel
    from orchestrator.run.checks import fe_cells_checked
    m = SlabModel(spec, "coupled")
    fe = m.fe
    centres = fe.nodes[fe.cell_nodes].mean(axis=1)
    read = fe_cells_checked(m)
    peak = np.zeros(len(centres))
    for n in range(1, spec.steps + 1):
        m.step()
        if n % every == 0:
            np.maximum(peak, fe.stress().max_principal, out=peak)
    grid = cell_grid(m.grid)
    zone = grid.box_mask(m.grid.hole_lo, m.grid.hole_hi)
    return centres[read], peak[read], cell_rings(grid, zone, centres[read])


def ring_ratios(small, large, floor, rings):
    """Per ring of the larger zone's run: the ratio large / small of the peaks of the cells
    both runs read, over those whose peak reaches `floor` in either. `small`, `large`: the
    (centres, peaks, rings) of peak_stress. {ring: (cells, p5, median, p95, max)}."""
    key = {tuple(c): i for i, c in enumerate(np.round(small[0], KEY_DIGITS))}
    out = {}
    for k in rings:
        pairs = [(key[tuple(c)], j) for j, c in enumerate(np.round(large[0], KEY_DIGITS))
                 if large[2][j] == k and tuple(c) in key]
        if not pairs:
            continue
        i, j = np.array(pairs).T
        a, b = small[1][i], large[1][j]
        hot = np.maximum(a, b) >= floor
        if hot.any():
            r = b[hot] / a[hot]
            out[k] = (int(hot.sum()), *np.percentile(r, [5, 50, 95]).tolist(), float(r.max()))
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scale", default="medium")
    p.add_argument("--impactor-speed", type=float, default=20.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--zones", default="0.5,0.9", help="the two box sides (m), smaller first")
    p.add_argument("--steps", type=int, default=700)
    p.add_argument("--every", type=int, default=10, help="steps between σ1 reads (the trip's)")
    a = p.parse_args(argv)
    try:
        sides = [float(s) for s in a.zones.split(",")]
    except ValueError:
        sides = []
    if len(sides) != 2 or not 0 < sides[0] < sides[1]:
        p.error(f"--zones: two box sides in m, smaller first, got {a.zones!r}")
    if a.steps < 1 or a.every < 1:
        p.error(f"--steps and --every: at least 1, got {a.steps} and {a.every}")
    try:
        spec = SlabSpec(scale=a.scale, impactor_speed=a.impactor_speed, seed=a.seed,
                        steps=a.steps)
        specs = [box_spec(spec, s) for s in sides]
    except ValueError as e:
        p.error(str(e))
    small, large = (peak_stress(s, a.every) for s in specs)
    ft = spec.tensile_strength
    print(f"{a.scale}, {a.impactor_speed:g} m/s, seed {a.seed}, {a.steps} steps, box zones "
          f"{sides[0]:g} and {sides[1]:g} m; ft {ft / 1e6:.2f} MPa")
    for side, (c, peak, ring) in zip(sides, (small, large)):
        first = spec.layers + 1
        near = peak[ring == first]
        print(f"  {side:g} m: cells read {len(c)}, peak σ1 {peak.max() / ft:.2f} ft; first ring "
              f"outside the band (ring {first}): {len(near)} cells, peak "
              f"{near.max(initial=0) / ft:.2f} ft, {np.count_nonzero(near >= 2 * ft)} past 2 ft")
        hot = np.argsort(-peak)[:HOTTEST]
        print("    hottest cells (x, y, z m: ring, peak): " + "; ".join(
            f"{c[i, 0]:.2f}, {c[i, 1]:.2f}, {c[i, 2]:.3f}: {ring[i]}, {peak[i] / ft:.2f} ft"
            for i in hot))
    rings = range(spec.layers + 1, spec.layers + 5)
    print(f"  peak ratio {sides[1]:g} m / {sides[0]:g} m run, cells past ft in either, per ring "
          f"of the {sides[1]:g} m zone: cells, p5, median, p95, max")
    for k, (n, p5, p50, p95, top) in ring_ratios(small, large, ft, rings).items():
        print(f"    ring {k}: {n:4d}  {p5:.3f} {p50:.3f} {p95:.3f} {top:.3f}")


if __name__ == "__main__":
    main()
