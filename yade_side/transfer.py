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


def link_energies(links, fields=None):
    """(normal, shear) elastic energy of each of the interactions `links` (YADE's), (m,) each,
    as the law's elasticEnergy() counts it: ½ |Fn|²/kn and ½ |Fs|²/ks with the forces of the
    last step; a link broken since it was made holds 0. `fields`: their CpmPhys's
    scene.LINK_FIELDS, if found already (memory.Fields)."""
    from yade_side.memory import Fields
    from yade_side.scene import LINK_FIELDS
    real = np.array([i.isReal for i in links], bool)
    normal, shear = np.zeros(len(links)), np.zeros(len(links))
    if real.any():
        rows = real                     # rows of `fields`: every link's
        if fields is None:              # or only the real links'
            fields = Fields([i.phys for i, r in zip(links, real) if r], LINK_FIELDS)
            rows = slice(None)
        square = lambda name: (fields.read(name)[rows] ** 2).sum(axis=1)
        normal[real] = 0.5 * square("normalForce") / fields.read("kn")[rows]
        shear[real] = 0.5 * square("shearForce") / fields.read("ks")[rows]
    return normal, shear


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
