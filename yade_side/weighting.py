"""The bridging domain's energy weight β inside the DE model itself (the "consistent"
weighting): instead of weighting nodal forces, the weighted energy β H_DE is what YADE
integrates. Knows nothing of the FE side: β comes from the orchestrator."""
import numpy as np

from yade_side import import_yade


def weight_spheres(ids, beta):
    """Make YADE integrate the weighted energy β H_DE of the spheres `ids`: mass and inertia
    × β, and the cross-section and stiffnesses of every link between two of them × the mean
    β of the two (CPM's forces are stresses × cross-section: the forces are weighted, the
    stresses and hence the damage are not). Call once the cohesive links exist; contacts
    made later are not weighted."""
    O = import_yade().Omega()
    ids = np.asarray(ids, int)
    index = np.full(ids.max() + 1, -1)
    index[ids] = np.arange(len(ids))
    for i in O.interactions:
        if max(i.id1, i.id2) >= len(index) or min(index[i.id1], index[i.id2]) < 0:
            continue
        w = 0.5 * (beta[index[i.id1]] + beta[index[i.id2]])
        if w < 1.0:
            p = i.phys
            p.crossSection, p.kn, p.ks = w * p.crossSection, w * p.kn, w * p.ks
    for j in np.flatnonzero(np.asarray(beta) < 1.0):
        state = O.bodies[int(ids[j])].state
        state.mass, state.inertia = beta[j] * state.mass, beta[j] * state.inertia
