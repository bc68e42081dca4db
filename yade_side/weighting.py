"""The bridging domain's energy weight β inside the DE model itself (the "consistent"
weighting): instead of weighting nodal forces, the weighted energy β H_DE is what YADE
integrates: masses and inertias × β, and every link between two weighted spheres (its
cross-section and stiffnesses) × the mean β of the two. CPM's forces are stresses ×
cross-section: the forces are weighted, the stresses and hence the damage are not. Knows
nothing of the FE side: β comes from the caller."""
import numpy as np

from yade_side import import_yade


def weight_masses(ids, beta):
    """Mass and inertia of each sphere `ids[j]` × beta[j] (call once)."""
    O = import_yade().Omega()
    for j in np.flatnonzero(np.asarray(beta) < 1.0):
        state = O.bodies[int(ids[j])].state
        state.mass, state.inertia = beta[j] * state.mass, beta[j] * state.inertia


def weight_links(ids, beta):
    """Cross-section and stiffnesses of every link between two of the spheres `ids` × the
    mean β of the two. Call once, when the cohesive links exist; contacts made later are
    not weighted."""
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
