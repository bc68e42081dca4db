"""The bridging domain's energy weight β inside the DE model itself (the "consistent"
weighting): instead of weighting nodal forces, the weighted energy β H_DE is what YADE
integrates: masses and inertias × β, and every link between two weighted spheres (its
cross-section and stiffnesses) × the mean β of the two. CPM's forces are stresses ×
cross-section: the forces are weighted, the stresses and hence the damage are not. Contacts
made later (a link broken and closed again, fragments meeting) are weighted alike, through
the spheres' materials. Knows nothing of the FE side: β comes from the caller."""
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
    mean β of the two, and the contacts made later alike (weight_contacts). Call once,
    when the cohesive links exist."""
    O = import_yade().Omega()
    ids, beta = np.asarray(ids, int), np.asarray(beta, float)
    index = np.full(ids.max() + 1, -1)
    index[ids] = np.arange(len(ids))
    index, n = index.tolist(), len(index)
    for j in np.flatnonzero(beta < 1.0):      # the weighted spheres' links only
        me = int(ids[j])
        for i in O.interactions.withBody(me):
            other = i.id2 if i.id1 == me else i.id1
            k = index[other] if other < n else -1
            if k < 0 or not i.isReal or (beta[k] < 1.0 and other < me):  # (once per link)
                continue
            w = 0.5 * (beta[j] + beta[k])
            p = i.phys
            p.crossSection, p.kn, p.ks = w * p.crossSection, w * p.kn, w * p.ks
    weight_contacts(ids, beta)


def weight_contacts(ids, beta):
    """The contacts made from now on weighted like the links: each sphere `ids[j]` with
    beta[j] < 1 gets its own copy of its material with young × beta[j]; YADE's Ip2 functor
    takes the mean of the two materials' young, so a new contact's stiffness is × the mean β
    of its spheres. After the links exist (weight_links calls it): a material read when the
    links are made would weight them twice. Unweighted, a contact closing on a band sphere of
    mass β m had 1/√β times its frequency: the step's margin gone at small β (a medium slab at
    40 m/s blew up so at 0.3 × the critical step, a broken band link closing again)."""
    yade = import_yade()
    O = yade.Omega()
    for j in np.flatnonzero(np.asarray(beta) < 1.0):   # set-up only
        body = O.bodies[int(ids[j])]
        values = {k: v for k, v in body.material.dict().items() if k not in ("id", "label")}
        values["young"] *= float(beta[j])
        body.material = O.materials[O.materials.append(type(body.material)(**values))]
