"""Concrete for YADE's CPM model: micro-parameters and the material they make.

The defaults are a calibration measured with YADE 2023.02a (quasi-static
uniaxial test of a 60×60×120 mm prism, 1,613 spheres, interaction radius 1.5):
E ≈ 31.0 GPa, ν ≈ 0.22, fc ≈ 31.1 MPa, ft ≈ 4.0 MPa — the slab's concrete.
"""
import math
from dataclasses import asdict, dataclass

from yade_side import import_yade


@dataclass
class ConcreteParams:
    young: float = 33e9                       # CPM contact modulus (Pa), not the macroscopic E
    poisson: float = 0.2                      # CPM shear/normal stiffness ratio, not ν
    frictionAngle: float = math.atan(0.8)     # rad
    sigmaT: float = 4.8e6                     # Pa
    epsCrackOnset: float = 1e-4
    relDuctility: float = 30.0
    density: float = 2400.0                   # BULK density (kg/m³) of the concrete
    # ξ: the shear strain's weight in the damage's equivalent strain √(⟨εN⟩² + ξ εT²); with 0
    # (YADE's default) a link slides at its cohesion for ever and never breaks in shear
    equivStrainShearContrib: float = 0.0

    def __post_init__(self):
        for name, value in asdict(self).items():
            low_ok = value >= 0 if name == "equivStrainShearContrib" else value > 0
            if not (isinstance(value, (int, float)) and low_ok and math.isfinite(value)):
                raise ValueError(f"concrete parameter {name} must be a "
                                 f"{'non-negative' if name == 'equivStrainShearContrib' else 'positive'}"
                                 f" number, got {value!r}")
        if self.frictionAngle >= math.pi / 2:
            raise ValueError(f"concrete frictionAngle must be below pi/2 rad, got "
                             f"{self.frictionAngle!r}")


def cpm_material(params, packing_fraction, label=None):
    """Append a CpmMat to O.materials and return its id. Spheres fill `packing_fraction` of
    the volume, so their density is the bulk density / packing_fraction."""
    if not 0 < packing_fraction <= 1:
        raise ValueError(f"packing fraction must be in (0, 1], got {packing_fraction!r}")
    yade = import_yade()
    p = asdict(params)
    density = p.pop("density") / packing_fraction
    mat = yade.wrapper.CpmMat(density=density, **p)
    if label:
        mat.label = label
    return yade.Omega().materials.append(mat)
