"""What links made under an FE strain hold against the FE cells they replace:
`python3 -m cases.slab.link_energy --scale small`.

A conversion (orchestrator/run/grow.py) puts new spheres on the FE's field and links them at
their reference lengths, so each link takes the FE's normal strain n·ε·n (and, with
`--grow-shear`, its shear). For a uniform strain ε their energy is ½ V ε : C_aff : ε, C_aff the
links' affine stiffness (yade_side.affine), where the cells held ½ V ε : C_FE : ε. Over every
strain, the ratio of the two lies between the generalised eigenvalues of C_aff against C_FE:
the strain-energy ratio a conversion of undamaged cells can give (docs/auto-zone.md, "The
links' energy at a conversion"). The slab's links are those of its first step (centres within
1.5 × the sum of the radii), over the whole slab's volume, and over its interior (two
diameters from every face) apart; C_FE is the scale's FE (its modulus the DE slab's bending
modulus) and, beside it, an isotropic solid of the packing's own uniaxial modulus (its
calibration's compression test, cases/slab/calibrations) with the same ν.
"""
import argparse

import numpy as np

from cases.slab.packings import make_packings
from cases.slab.scales import SCALES, SLAB, concrete_set
from cases.slab.spec import SlabSpec
from yade_side.affine import affine_stiffness, energy_ratio_bounds, isotropic_stiffness
from yade_side.scene import link_pairs


def uniaxial_stress_strain(nu):
    """The Mandel strain of uniaxial stress along x in an isotropic solid of ratio nu."""
    return np.array([1.0, -nu, -nu, 0.0, 0.0, 0.0])


def measure(scale, seed=1):
    """The links' affine stiffness of the slab of `scale` (packing `seed`) against the FE's
    and the packing's uniaxial modulus: a dict of figures."""
    spec = SlabSpec(scale=scale, seed=seed)
    packs = make_packings(spec)
    c, r = packs.slab_centres, packs.slab_radii
    pairs = link_pairs(c, r, np.ones(len(c), bool))
    cpm = spec.cpm
    specimen_young = concrete_set(scale, spec.concrete).young
    fe = isotropic_stiffness(spec.young, spec.poisson)
    packing = isotropic_stiffness(specimen_young, spec.poisson)
    e = uniaxial_stress_strain(spec.poisson)
    inset = 4 * r.max()
    mid = 0.5 * (c[pairs[:, 0]] + c[pairs[:, 1]])
    interior = np.all((mid > inset) & (mid < np.array(SLAB) - inset), axis=1)
    out = {"scale": scale, "seed": seed, "spheres": len(c), "links": len(pairs),
           "fe_young": spec.young, "packing_young": float(specimen_young), "nu": spec.poisson}
    for name, keep, volume in (("slab", slice(None), float(np.prod(SLAB))),
                               ("interior", interior,
                                float(np.prod(np.array(SLAB) - 2 * inset)))):
        for shear in (False, True):
            C = affine_stiffness(c, r, pairs[keep], cpm["young"], cpm["poisson"], volume,
                                 shear=shear)
            key = f"{name}_{'normal_and_shear' if shear else 'normal'}"
            out[key] = {"vs_fe": energy_ratio_bounds(C, fe),
                        "vs_fe_uniaxial": float(e @ C @ e / (e @ fe @ e)),
                        "vs_packing": energy_ratio_bounds(C, packing),
                        "vs_packing_uniaxial": float(e @ C @ e / (e @ packing @ e))}
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scale", choices=sorted(SCALES), action="append",
                   help="scale (repeat for several; default: every scale)")
    p.add_argument("--seed", type=int, default=1, help="the packing's seed (default 1)")
    a = p.parse_args(argv)
    for scale in a.scale or list(SCALES):
        m = measure(scale, a.seed)
        print(f"{scale} (seed {m['seed']}): {m['spheres']} spheres, {m['links']} links; FE "
              f"{m['fe_young'] / 1e9:.1f} GPa, the packing's uniaxial "
              f"{m['packing_young'] / 1e9:.1f} GPa, ν {m['nu']:.3f}")
        for key in ("slab_normal", "slab_normal_and_shear", "interior_normal",
                    "interior_normal_and_shear"):
            f = m[key]
            print(f"  {key:26s} links' energy / FE's {f['vs_fe'][0]:.2f}-{f['vs_fe'][1]:.2f} "
                  f"(uniaxial stress {f['vs_fe_uniaxial']:.2f}); / the packing's "
                  f"{f['vs_packing'][0]:.2f}-{f['vs_packing'][1]:.2f} "
                  f"({f['vs_packing_uniaxial']:.2f})")


if __name__ == "__main__":
    main()
