"""The paper-scale slab with a graded FE mesh: the bridging band's share of the coupled spheres
and the FE critical time step, for bands of `layers` cells of `ratio` sphere diameters.

    /usr/bin/python3 -m cases.graded_band

Sphere counts come from the geometry: the band is the box-shaped shell (Chebyshev depth, as
orchestrator.coupling.bridging.BoxZone) of width layers × h around the DE box, through the thickness,
and holds N_V × its volume spheres. N_V, the spheres per m³ of the zone and band, is measured
on the paper-scale coupled model with a 0.6 m box and 3 layers (PAPER_COUPLED, MEASURED).
"""
from dataclasses import dataclass

import numpy as np

from cases.slab import SCALES, SLAB, SlabSpec, slab_grid
from cases.slab.scales import concrete_set

# a paper-scale coupled model (docs/benchmarks.md of 2026-11): slab spheres (28,365 less the
# impactor's 2,042) in the DE box of MEASURED + 3 layers of 0.0714 m cells; the bridging spheres
# among them
PAPER_COUPLED = {"slab_spheres": 26323, "bridging": 17343, "impactor": 2042}
MEASURED = {"scale": "paper", "de_zone": 0.6, "layers": 3}


@dataclass
class BandFigures:
    layers: int
    ratio: float          # band cell / sphere diameter
    width: float          # m
    coupled: float        # slab spheres in the zone and band (estimated)
    band: float
    share: float          # band / coupled slab spheres
    share_with_impactor: float
    fe_critical: float    # s, graded mesh (None if not computed)
    de_critical: float    # s, PWaveTimeStep of the spheres


def zone_box(spec):
    g = slab_grid(spec)
    return g.hole_lo, g.hole_hi


def shell_area(a, b, width):
    """Area of the square-cornered band of `width` around an a × b rectangle."""
    return (a + 2 * width) * (b + 2 * width) - a * b


def sphere_density():
    """Slab spheres per m³ of the measured paper-scale zone + band."""
    spec = SlabSpec(**MEASURED)
    lo, hi = zone_box(spec)
    a, b = (hi - lo)[:2]
    width = spec.layers * slab_grid(spec).h
    return PAPER_COUPLED["slab_spheres"] / ((a * b + shell_area(a, b, width)) * SLAB[2])


def zone_scale_for_share(a, b, width, share):
    """Factor s by which the a × b DE box must grow (same aspect) for a band of `width` to hold
    `share` of the zone + band: (sa + 2w)(sb + 2w) = sa sb / (1 - share)."""
    # s² ab share/(1-share) - 2w(a+b) s - 4w² = 0
    A, B, C = a * b * share / (1 - share), -2 * width * (a + b), -4 * width**2
    return (-B + np.sqrt(B * B - 4 * A * C)) / (2 * A)


def de_critical_step(scale="paper", packing_fraction=None):
    """PWaveTimeStep of the scale's spheres: R sqrt(ρ_s / E) with ρ_s = 2400 / φ (material.py),
    φ the slab packing's fraction (default: 120,024 spheres of R = 11.2 mm in the slab)."""
    r = SCALES[scale].radius
    phi = packing_fraction or 120024 * 4 / 3 * np.pi * r**3 / np.prod(SLAB)
    return r * np.sqrt(2400.0 / phi / concrete_set(scale, "plain").cpm["young"])


def graded_fe_critical_step(spec, layers, h, ratio_max=1.2, h_max=None, weighted=False):
    """Critical step of the FE part on the graded mesh (fenicsx_side.mesh.graded_axis) with
    `layers` cells of h around the DE box of `spec`, the thickness cells as its grid's."""
    from fenicsx_side.mesh import graded_axis, tensor_box_with_hole
    from fenicsx_side.model import ElasticModel, face
    from orchestrator.coupling.bridging import BoxZone, Bridging
    lo, hi = zone_box(spec)
    cap = slab_grid(spec).h if h_max is None else h_max
    xs = graded_axis(0.0, SLAB[0], lo[0], hi[0], h, layers, ratio_max, max(cap, h))
    ys = graded_axis(0.0, SLAB[1], lo[1], hi[1], h, layers, ratio_max, max(cap, h))
    zs = np.linspace(0.0, SLAB[2], slab_grid(spec).n[2] + 1)
    msh = tensor_box_with_hole(xs, ys, zs, lo, hi)
    weight = Bridging(BoxZone(lo, hi), layers, h).alpha if weighted else None
    fe = ElasticModel(msh, spec.young, spec.poisson, spec.density,
                      [(face(0, 0.0), (2,)), (face(0, SLAB[0]), (2,))], weight=weight)
    return fe.critical_dt(), len(fe.nodes)


def band_figures(layers, ratio, with_fe=False):
    spec = SlabSpec(**MEASURED)
    lo, hi = zone_box(spec)
    a, b = (hi - lo)[:2]
    h = ratio * 2 * SCALES["paper"].radius
    width = layers * h
    n_v = sphere_density() * SLAB[2]
    band, zone = n_v * shell_area(a, b, width), n_v * a * b
    fe = graded_fe_critical_step(spec, layers, h)[0] if with_fe else None
    return BandFigures(layers, ratio, width, zone + band, band, band / (zone + band),
                       band / (zone + band + PAPER_COUPLED["impactor"]), fe, de_critical_step())


def main():
    spec = SlabSpec(**MEASURED)
    lo, hi = zone_box(spec)
    h_uniform = slab_grid(spec).h
    print(f"paper scale: DE box {np.round(hi - lo, 4)[:2].tolist()} m, R = {SCALES['paper'].radius} m, "
          f"spheres per m^3 of zone + band {sphere_density():.0f}, its cells "
          f"{h_uniform:.4f} m = {h_uniform / (2 * SCALES['paper'].radius):.2f} d, thickness cells "
          f"{SLAB[2] / slab_grid(spec).n[2]:.4f} m")
    measured = band_figures(spec.layers, h_uniform / (2 * SCALES["paper"].radius))
    print(f"the measured zone (uniform): band {measured.band:.0f} of {measured.coupled:.0f} slab "
          f"spheres = {measured.share:.1%} ({measured.share_with_impactor:.1%} with the "
          f"impactor; measured "
          f"{PAPER_COUPLED['bridging']} = "
          f"{PAPER_COUPLED['bridging'] / (measured.coupled + PAPER_COUPLED['impactor']):.1%})")
    print("layers  cell/d  width(m)  coupled  band  share  share+impactor  FE dt/DE dt")
    for layers, ratio in ((3, 4.0), (3, 3.0), (3, 2.0), (2, 2.0), (1, 2.0), (3, 1.5), (2, 1.5),
                          (3, 1.2), (3, 1.0)):
        f = band_figures(layers, ratio, with_fe=True)
        print(f"{layers:6d}  {ratio:6.2f}  {f.width:8.4f}  {f.coupled:7.0f}  {f.band:5.0f}  "
              f"{f.share:5.1%}  {f.share_with_impactor:14.1%}  "
              f"{f.fe_critical / f.de_critical:6.3f}")
    a, b = (hi - lo)[:2]
    for layers, ratio in ((3, 2.0), (3, 4.0)):
        k = zone_scale_for_share(a, b, layers * ratio * 2 * SCALES["paper"].radius, 0.35)
        print(f"a 35 % band share with {layers} layers of {ratio} d needs a DE box "
              f"{k * a:.3f} x {k * b:.3f} m ({k:.2f} x the measured box)")
    t, nodes = graded_fe_critical_step(spec, 3, 4 * SCALES["paper"].radius, weighted=True)
    print(f"3 layers of 2 d, consistent weighting (alpha in K and M): FE dt / DE dt = "
          f"{t / de_critical_step():.3f}, {nodes} nodes")
    t, nodes = graded_fe_critical_step(spec, spec.layers, h_uniform)
    print(f"its uniform mesh as a graded one (3 layers of {h_uniform:.4f} m): FE dt / DE dt = "
          f"{t / de_critical_step():.3f}, {nodes} nodes")


if __name__ == "__main__":
    main()
