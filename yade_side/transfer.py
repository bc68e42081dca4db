"""What a DE zone grown in place (orchestrator.run.grow) writes into the links it made, and
reads of them: where the FE's state goes in a CPM link's history (yade_side.memory), their
elastic energy, and the scene's shear kinematics."""
import numpy as np

from yade_side import import_yade

# the 19 history doubles (memory.HISTORY): 7 scalars, then sigmaT, Fs, epsTPl, epsT, whose
# signs follow the link's normal (from id1 to id2)
EPS_N_PL = 6
EPS_T = slice(16, 19)
SAMPLE = 256   # links on which the history's place in memory is verified


def link_energies(links, phys=None):
    """(normal, shear) elastic energy of each of the interactions `links` (YADE's), (m,) each,
    as the law's elasticEnergy() counts it: ½ |Fn|²/kn and ½ |Fs|²/ks with the forces of the
    last step; a link broken since it was made holds 0. `phys`: their CpmPhys, if read."""
    phys = (i.phys for i in links) if phys is None else phys
    parts = [(0.5 * p.normalForce.squaredNorm() / p.kn,
              0.5 * p.shearForce.squaredNorm() / p.ks) if i.isReal else (0.0, 0.0)
             for i, p in zip(links, phys)]
    return tuple(np.array(column, float) for column in zip(*parts)) if parts else \
        (np.zeros(0), np.zeros(0))


def lever_arms_are_radii():
    """True when the scene's Ig2_Sphere_Sphere_ScGeom takes the radii as lever arms of the
    shear kinematics (YADE's default, avoidGranularRatcheting), False for the contact point."""
    yade = import_yade()
    for e in yade.Omega().engines:
        if isinstance(e, yade.wrapper.InteractionLoop):
            for f in e.geomDispatcher.functors:
                if isinstance(f, yade.wrapper.Ig2_Sphere_Sphere_ScGeom):
                    return bool(f.avoidGranularRatcheting)
    return True
