"""A scene's state carried into another scene of the same packing (the model of a grown DE
zone, built afresh): bodies by a correspondence the caller gives, and their CPM
interactions with their history (yade_side.memory: O.save does not keep it, nor would a
rebuilt scene): links broken in the old scene are erased in the new, and the new links may
be given a history (a shear strain, a normal plastic strain). Frictional contacts (the
impactor on the slab, a broken link closed again) are made again with their reference
penetration: one the collider made anew would take the current penetration as its reference
and start without force.
"""
from dataclasses import dataclass

import numpy as np

from yade_side import import_yade
from yade_side.memory import (NORMAL_WIDTH, WIDTH, Blocks, HistoryBlocks, find_normal_offset,
                               find_offset)
from yade_side.scene import settle_forces

# the 19 history doubles (memory.HISTORY): 7 scalars, then sigmaT, Fs, epsTPl, epsT, whose
# signs follow the link's normal (from id1 to id2)
_VECTORS = slice(7, WIDTH)
EPS_N_PL = 6
EPS_T = slice(16, 19)
SAMPLE = 256   # links on which the history's place in memory is verified (checkpoints: all)


@dataclass
class Links:
    """The CPM interactions of a scene: `pairs` (m, 2) as indices into the captured bodies,
    their history (m, 19), ScGeom normal (m, 3), shear modulus G (m,; 0 once released),
    reference penetration refPD (m,) and whether each is a cohesive link (m,)."""
    pairs: np.ndarray
    history: np.ndarray
    normal: np.ndarray
    shear_modulus: np.ndarray
    ref_penetration: np.ndarray
    cohesive: np.ndarray


def _cpm(O, yade, index):
    """The real CPM interactions between bodies of `index` (id → position, -1: not one)."""
    cpm, index = yade.wrapper.CpmPhys, index.tolist()
    n = len(index)
    return [i for i in O.interactions.all(True)
            if i.id1 < n and i.id2 < n and index[i.id1] >= 0 and index[i.id2] >= 0
            and isinstance(i.phys, cpm)]


def _normals(links):
    """The ScGeom normals of the interactions `links`, one gather: Blocks (m, 3)."""
    geoms = [i.geom for i in links]
    return Blocks(geoms, find_normal_offset(geoms, SAMPLE) if geoms else 0, NORMAL_WIDTH)


def capture_links(ids):
    """Interactions of the current scene between the bodies `ids` (their index in `ids`
    names them)."""
    yade = import_yade()
    index = _index(ids)
    links = _cpm(yade.Omega(), yade, index)
    offset = find_offset(links, SAMPLE)
    phys = [i.phys for i in links]
    pairs = np.array([(i.id1, i.id2) for i in links], int).reshape(-1, 2)
    scalars = np.array([(p.G, p.refPD, p.isCohesive) for p in phys], float).reshape(-1, 3)
    history = HistoryBlocks(phys, offset).read() if phys else np.empty((0, WIDTH))
    normal = _normals(links).read() if links else np.empty((0, 3))
    return Links(index[pairs], history, normal, scalars[:, 0], scalars[:, 1],
                 scalars[:, 2].astype(bool))


def restore_links(links, ids, old_of, new_history=None):
    """Into the current scene (its links made, its bodies `ids` where the captured ones
    are; old_of: index of each into the captured bodies, -1 for a body the old scene did not
    have): each interaction between two old bodies takes its captured history, normal, G and
    refPD, a link the old scene had lost (it broke there) is erased, a contact it had is
    made (the old scene's bodies are all in the new one); with `new_history`, the links with
    a new body get their history from new_history(ends, normal, values), which writes into
    their history values (m, 19) (ends: their bodies' indices into `ids`).
    Returns the counts of each kind and the new links' (id1, id2). The scene must not couple
    inside its step (settle_forces)."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    index, old_of = _index(ids), np.asarray(old_of, int)
    found = _cpm(O, yade, index)
    ends = index[np.array([(i.id1, i.id2) for i in found], int).reshape(-1, 2)]
    olds = old_of[ends]
    is_new = (olds < 0).any(axis=1)
    k = np.full(len(found), -1)
    k[~is_new] = _captured(links.pairs, olds[~is_new])
    sign = np.ones(len(found))
    sign[k >= 0] = np.where(olds[k >= 0, 0] == links.pairs[k[k >= 0], 0], 1.0, -1.0)
    erase = [(found[j].id1, found[j].id2) for j in np.flatnonzero(~is_new & (k < 0))]
    carry = [(found[j], k[j], sign[j]) for j in np.flatnonzero(k >= 0)]
    new = [(found[j], ends[j, 0], ends[j, 1]) for j in np.flatnonzero(is_new)]
    rest = np.setdiff1d(np.arange(len(links.pairs)), k)   # contacts to make, in capture order
    for pair in erase:
        O.interactions.erase(*pair)
    offset = find_offset([i for i, _, _ in carry] + [i for i, _, _ in new], SAMPLE)
    _write(carry, links, offset)
    if new_history is not None and new:
        ends = ends[is_new]
        normal = _normals([i for i, _, _ in new]).read()
        blocks = HistoryBlocks([i.phys for i, _, _ in new], offset)
        values = blocks.read()
        new_history(ends, normal, values)
        blocks.write(values)
    # contacts: made now, their stiffness and reference set by the law at their first step
    # (a step of zero length, which leaves the links above as they are), then their history
    id_of = np.full(max(old_of.max(initial=-1), links.pairs.max(initial=-1)) + 1, -1)
    id_of[old_of[old_of >= 0]] = np.asarray(ids)[old_of >= 0]
    made, kept, lost = [], [], 0
    for k in rest:                       # (links broken and erased are not here)
        a, b = (int(j) for j in id_of[links.pairs[k]])
        try:
            i = utils.createInteraction(a, b)
        except RuntimeError:             # the bodies do not touch where they are now
            lost += 1
            continue
        made.append((i.id1, i.id2, k, 1.0 if i.id1 == a else -1.0))
    if made:
        settle_forces()
        kept = [(O.interactions[a, b], k, sign) for a, b, k, sign in made
                if O.interactions.has(a, b) and O.interactions[a, b].isReal]
        lost += len(made) - len(kept)
        if offset is None:
            offset = find_offset([i for i, _, _ in kept], SAMPLE)
        _write(kept, links, offset)
    counts = {"carried": len(carry), "contacts": len(kept), "contacts_lost": lost,
              "erased": len(erase), "new": len(new)}
    return counts, [(i.id1, i.id2) for i, _, _ in new]


def _captured(pairs, wanted):
    """For each pair of `wanted` (m, 2), the index of the same pair in `pairs` (either
    order), or -1."""
    if not len(pairs) or not len(wanted):
        return np.full(len(wanted), -1)
    base = int(max(pairs.max(), wanted.max())) + 1
    key = lambda p: np.sort(p, axis=1) @ np.array([base, 1])
    order = np.argsort(key(pairs))
    keys = key(pairs)[order]
    at = np.minimum(np.searchsorted(keys, key(wanted)), len(keys) - 1)
    return np.where(keys[at] == key(wanted), order[at], -1)


def link_energy(pairs):
    """(normal, shear) elastic energy of the links `pairs` (id1, id2), as the law's
    elasticEnergy() sums it: ½ |Fn|²/kn + ½ |Fs|²/ks with the forces of the last step."""
    O = import_yade().Omega()
    normal = shear = 0.0
    for a, b in pairs:
        if O.interactions.has(a, b) and O.interactions[a, b].isReal:   # else broken now
            p = O.interactions[a, b].phys
            normal += 0.5 * p.normalForce.squaredNorm() / p.kn
            shear += 0.5 * p.shearForce.squaredNorm() / p.ks
    return normal, shear


def _write(items, links, offset):
    """Captured links into interactions: items (interaction, k, sign), link k of `links`
    into the interaction (sign -1: its bodies in the other order). The history in one
    scatter; the normal of every one; G, refPD and isCohesive where they differ from a link
    made at reference positions (released shear, a contact)."""
    if not items:
        return
    k = np.array([k for _, k, _ in items])
    sign = np.array([s for _, _, s in items])
    values = links.history[k]
    values[:, _VECTORS] *= sign[:, None]
    HistoryBlocks([i.phys for i, _, _ in items], offset).write(values)
    _normals([i for i, _, _ in items]).write(links.normal[k] * sign[:, None])
    released, contact = links.shear_modulus[k] == 0, ~links.cohesive[k]
    for j in np.flatnonzero(released | contact):
        p = items[j][0].phys
        if released[j]:
            p.G = 0.0
        if contact[j]:
            p.isCohesive = False
            p.refPD = float(links.ref_penetration[k[j]])


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


def _index(ids):
    ids = np.asarray(ids, int)
    index = np.full(ids.max(initial=-1) + 1, -1)
    index[ids] = np.arange(len(ids))
    return index
