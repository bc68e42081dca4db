"""A 1D chain of YADE spheres along x with elastic cohesive links that never break: the fine
model of the 1D wave study. Only x translations are free.

CPM's link stiffness between two touching spheres of radius R is k = E_c π R² / (2R) (its
contact modulus E_c times the cross-section π min(R)² over the length; measured here), so a
chain that carries a bar of modulus E, density ρ and cross-section A at spacing L = 2R, with
long-wave speed √(E/ρ) and the bar's impedance, has k = E A / L and sphere mass ρ A L.
"""
import numpy as np

from yade_side import import_yade


def chain_material(E, rho, area, spacing):
    """CpmMat whose links give k = E A / L and whose spheres weigh ρ A L (never damaged)."""
    yade = import_yade()
    R = 0.5 * spacing
    young = E * area / (np.pi * R * R)
    density = rho * area * spacing / (4.0 / 3.0 * np.pi * R**3)
    return yade.wrapper.CpmMat(young=young, density=density, poisson=1.0, frictionAngle=0.5,
                               sigmaT=1e30, epsCrackOnset=1e30, relDuctility=1.0,
                               neverDamage=True)


def build_chain(x0, spacing, n, E, rho, area):
    """Append n spheres at x0 + i L (y = z = 0 shifted to `x0`'s y, z) and return their ids.
    Call scene.cpm_engines and create_cohesive_links afterwards."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    mat = O.materials.append(chain_material(E, rho, area, spacing))
    x0 = np.asarray(x0, float)
    ids = O.bodies.append([utils.sphere(tuple(x0 + (i * spacing, 0, 0)), 0.5 * spacing,
                                        material=mat) for i in range(n)])
    for i in ids:
        O.bodies[i].state.blockedDOFs = "yzXYZ"
    return np.asarray(ids, dtype=int)
