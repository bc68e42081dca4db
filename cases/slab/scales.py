"""The slab's dimensions and its one table of scales: what depends on the sphere size, and
the CPM sets fitted on each scale's packing (docs/slab.md, docs/calibration.md)."""
from dataclasses import dataclass

SLAB = (2.5, 2.0, 0.28)


@dataclass(frozen=True)
class Scale:
    """What depends on the sphere size (docs/slab.md, docs/calibration.md)."""
    radius: float        # m
    steps: int           # 5 ms after contact: the far sensors reach their peak (~2.5-4 ms)
    fe_young: float      # FE modulus: the bending modulus of the DE slab it stands for
    cpm: dict            # CPM micro-parameters fitted to E = 31 GPa, fc = 31 MPa
    tensile_strength: float  # ft the same calibration measured (the post-run FE check)
    de_zone: float       # side of the DE zone along x (m)
    full_width: bool     # the DE zone spans the slab's whole width (y)
    gf_cpm: dict = None  # concrete "gf": the set also fitted to the fracture energy (None: none)
    gf_tensile_strength: float = None  # ft of that set (its separation test)


# - radius: 25,072 spheres in the full medium model, 122,066 at paper scale (the paper's
#   Table 1: 120,808);
# - fe_young: measured by quasi-static 3-point bending of a strip of the slab's packing
#   against the same strip in FE on the scale's grid (`python3 -m cases.slab.bending --scale
#   S`): 5.6-7.6 sphere diameters through 0.28 m bend like 17-21 GPa, not the 31 GPa of their
#   uniaxial test; 12.5 diameters like 24.9 GPa;
# - cpm: `python3 -m cli calibrate --scale S` on a 0.56 × 0.56 × 0.28 m piece of the
#   slab's packing, broken links deleted (E 31.02 / 31.00 / 30.98 GPa, fc 30.90 / 31.02 /
#   30.90 MPa), on the packings of YADE's memo; on today's deterministic ones small and medium
#   measure E 26.54 / 29.58 GPa, fc 28.36 / 28.63 MPa (docs/calibration.md: to be refitted);
# - de_zone, full_width: at 40 m/s damage reaches the free edges y = 0, 2 within 5 ms; a strip
#   x ∈ [0.83, 1.67] m holds 98.9 % of the full small model's damaged volume, x ∈ [0.8, 1.7] m
#   96.7 % of the medium one's;
# - gf_cpm, gf_tensile_strength: `calibrate --shear-contrib 0.1`, relDuctility at its lower
#   bound 0.1 (docs/calibration.md, "Fracture energy"), measured on today's packings: E 31.00 /
#   31.00 GPa, fc 29.89 / 30.89 MPa, Gf 483 / 282 J/m² (the target 135 J/m² is missed); no set
#   at paper scale.
SCALES = {
    "small": Scale(0.025, 3300, 17.2e9,
                   dict(young=3.301e10, sigmaT=5.702e6, epsCrackOnset=1.188e-4),
                   4.30e6, 0.6, True,
                   dict(young=3.8457e10, sigmaT=1.4411e7, epsCrackOnset=2.5769e-4,
                        relDuctility=0.1, equivStrainShearContrib=0.1), 5.88e6),
    "medium": Scale(0.0185, 4400, 21.0e9,
                    dict(young=3.137e10, sigmaT=4.375e6, epsCrackOnset=9.561e-5),
                    3.76e6, 0.9, True,
                    dict(young=3.2713e10, sigmaT=1.2713e7, epsCrackOnset=2.6635e-4,
                         relDuctility=0.1, equivStrainShearContrib=0.1), 5.23e6),
    "paper": Scale(0.0112, 300, 24.9e9,
                   dict(young=2.833e10, sigmaT=3.519e6, epsCrackOnset=8.476e-5),
                   3.14e6, 0.6, False),
}
# the fields that default to the table's value of the scale (None: take the scale's)
PER_SCALE = {"radius": "radius", "steps": "steps", "young": "fe_young",
             "tensile_strength": "tensile_strength", "de_zone": "de_zone",
             "full_width": "full_width"}
# the slab's CPM concrete: "plain" fitted to E and fc (relDuctility 30, no shear damage), "gf"
# also brought towards the fracture energy (docs/calibration.md)
CONCRETES = ("plain", "gf")
