"""The bridging domain's energy weight β inside the DE model itself (the "consistent"
weighting): instead of weighting nodal forces, the weighted energy β H_DE is what YADE
integrates: masses and inertias × β, and every link between two weighted spheres (its
cross-section and stiffnesses) × the mean β of the two. CPM's forces are stresses ×
cross-section: the forces are weighted, the stresses and hence the damage are not. Contacts
made later (a link broken and closed again, fragments meeting) are weighted alike, through
the spheres' materials. Knows nothing of the FE side: β comes from the caller."""
import numpy as np

from yade_side import import_yade


def weight_masses(ids, beta, unweighted=None):
    """Mass and inertia of each sphere `ids[j]` = beta[j] × its unweighted ones: those it has
    now, which must be unweighted (call once; spheres of β 1 are left as they are), or those
    given, `unweighted` = (mass, scalar inertia) arrays (every sphere written)."""
    O = import_yade().Omega()
    beta = np.asarray(beta, float)
    if unweighted is None:
        for j in np.flatnonzero(beta < 1.0):
            state = O.bodies[int(ids[j])].state
            state.mass, state.inertia = beta[j] * state.mass, beta[j] * state.inertia
        return
    for j, (mass, inertia) in enumerate(zip(*unweighted)):
        state = O.bodies[int(ids[j])].state
        state.mass, state.inertia = beta[j] * mass, (beta[j] * inertia,) * 3


def weight_links(ids, beta, before=None):
    """Cross-section and stiffnesses of every link between two of the spheres `ids` × the
    mean β of the two, and the contacts made later alike (weight_contacts). Call once, when
    the cohesive links exist; or, for spheres that carried the weights `before` (a DE zone
    grown in place), × the ratio of the mean β after to before, on every interaction of a
    sphere whose β changed (a link: cross-section and stiffnesses; a contact: E, G and
    stiffnesses, which its spheres' weighted materials gave it). Interactions with a sphere
    not in `ids` are left as they are (links made later take their weight when made:
    yade_side.scene.add_cohesive_links)."""
    O = import_yade().Omega()
    ids, beta = np.asarray(ids, int), np.asarray(beta, float)
    before = np.ones(len(ids)) if before is None else np.asarray(before, float)
    index = np.full(ids.max() + 1, -1)
    index[ids] = np.arange(len(ids))
    changed = beta != before
    index, n = index.tolist(), len(index)
    for j in np.flatnonzero(changed):         # the reweighted spheres' interactions only
        me = int(ids[j])
        for i in O.interactions.withBody(me):
            other = i.id2 if i.id1 == me else i.id1
            k = index[other] if other < n else -1
            if k < 0 or not i.isReal or (changed[k] and other < me):    # (once per link)
                continue
            w = (beta[j] + beta[k]) / (before[j] + before[k])
            p = i.phys
            if p.isCohesive:
                p.crossSection, p.kn, p.ks = w * p.crossSection, w * p.kn, w * p.ks
            else:
                p.E, p.G, p.kn, p.ks = w * p.E, w * p.G, w * p.kn, w * p.ks
    weight_contacts(ids, beta, before)


# the label of a sphere's own copy of its material (weight_contacts): no other body holds it
OWN_COPY = "beta-weighted"


def weight_contacts(ids, beta, before=None):
    """The contacts made from now on weighted like the links: each sphere `ids[j]` with
    beta[j] < 1 gets its own copy of its material with young × beta[j] (with `before`, the
    weights its material carries now: young × beta[j] / before[j] where they differ, its own
    copy reweighted in place: a zone that grows adds copies only for the spheres it weights
    anew); YADE's Ip2 functor takes the mean of the two materials' young, so a new contact's
    stiffness is × the mean β of its spheres. After the links exist (weight_links calls it):
    a material read when the links are made would weight them twice. Unweighted, a contact
    closing on a band sphere of mass β m had 1/√β times its frequency: the step's margin gone
    at small β (a medium slab at 40 m/s blew up so at 0.3 × the critical step, a broken band
    link closing again)."""
    yade = import_yade()
    O = yade.Omega()
    beta = np.asarray(beta, float)
    before = np.ones(len(beta)) if before is None else np.asarray(before, float)
    for j in np.flatnonzero(beta != before):   # set-up only
        body = O.bodies[int(ids[j])]
        material, factor = body.material, float(beta[j] / before[j])
        if material.label == OWN_COPY:
            material.young *= factor
            continue
        values = {k: v for k, v in material.dict().items() if k not in ("id", "label")}
        values["young"] *= factor
        body.material = O.materials[O.materials.append(type(material)(label=OWN_COPY,
                                                                      **values))]
