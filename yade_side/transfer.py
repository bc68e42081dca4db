"""A scene's state carried into another scene of the same packing (the model of a grown DE
zone, built afresh): bodies by a correspondence the caller gives, and their CPM
interactions with their history (yade_side.memory: O.save does not keep it, nor would a
rebuilt scene): links broken in the old scene are erased in the new, and the new links get
their shear strain. Frictional contacts (the impactor on the slab, a broken link closed
again) are made again with their reference penetration: one the collider made anew would
take the current penetration as its reference and start without force.
"""
from dataclasses import dataclass

import numpy as np

from yade_side import import_yade
from yade_side.memory import WIDTH, find_offset, history_block
from yade_side.scene import settle_forces

# the 19 history doubles (memory.HISTORY): 7 scalars, then sigmaT, Fs, epsTPl, epsT, whose
# signs follow the link's normal (from id1 to id2)
_VECTORS = slice(7, WIDTH)
EPS_T = slice(16, 19)
OMEGA, KAPPA = 0, 5
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
    return [i for i in O.interactions
            if i.isReal and isinstance(i.phys, yade.wrapper.CpmPhys)
            and max(i.id1, i.id2) < len(index) and min(index[i.id1], index[i.id2]) >= 0]


def capture_links(ids):
    """Interactions of the current scene between the bodies `ids` (their index in `ids`
    names them)."""
    yade = import_yade()
    index = _index(ids)
    links = _cpm(yade.Omega(), yade, index)
    offset = find_offset(links, SAMPLE)
    column = lambda get: np.array([get(i) for i in links])
    return Links(column(lambda i: (index[i.id1], index[i.id2])).reshape(-1, 2).astype(int),
                 column(lambda i: history_block(i.phys, offset)).reshape(-1, WIDTH),
                 column(lambda i: tuple(i.geom.normal)).reshape(-1, 3),
                 column(lambda i: i.phys.G), column(lambda i: i.phys.refPD),
                 column(lambda i: i.phys.isCohesive).astype(bool))


def restore_links(links, ids, old_of, start=None):
    """Into the current scene (its links made, its bodies `ids` where the captured ones
    are; old_of: index of each into the captured bodies, -1 for a body the old scene did not
    have): each interaction between two old bodies takes its captured history, normal, G and
    refPD, a link the old scene had lost (it broke there) is erased, a contact it had is
    made (the old scene's bodies are all in the new one); with `start`, the links with a new
    body get (epsT (m, 3), ω (m,)) = start(ends, normal) (ends: their bodies' indices into
    `ids`), ω with its strain history κ (damage_history).
    Returns the counts of each kind and the new links' (id1, id2). The scene must not couple
    inside its step (settle_forces)."""
    yade = import_yade()
    from yade import utils
    O = yade.Omega()
    index, old_of = _index(ids), np.asarray(old_of, int)
    captured = {(int(a), int(b)): k for k, (a, b) in enumerate(links.pairs)}
    erase, new, carry = [], [], []
    for i in _cpm(O, yade, index):
        j1, j2 = index[i.id1], index[i.id2]
        a, b = old_of[j1], old_of[j2]
        if a < 0 or b < 0:
            new.append((i, j1, j2))
            continue
        k, sign = captured.pop((a, b), None), 1.0
        if k is None:
            k, sign = captured.pop((b, a), None), -1.0
        if k is None:
            erase.append((i.id1, i.id2))
        else:
            carry.append((i, k, sign))
    for pair in erase:
        O.interactions.erase(*pair)
    offset = find_offset([i for i, _, _ in carry] + [i for i, _, _ in new], SAMPLE)
    for i, k, sign in carry:
        _write(i, links, k, sign, offset)
    if start is not None and new:
        ends = np.array([(j1, j2) for _, j1, j2 in new])
        normal = np.array([tuple(i.geom.normal) for i, _, _ in new])
        eps_t, omega = start(ends, normal)
        if any(i.phys.damLaw != 1 for i, _, _ in new):
            raise ValueError("a link's damage is carried for CPM's exponential softening "
                             "(CpmMat.damLaw 1) only")
        omega = np.minimum(omega, 1 - 1e-9)
        phys = [i.phys for i, _, _ in new]
        kappa = damage_history(omega, np.array([p.epsCrackOnset for p in phys]),
                               np.array([p.epsFracture for p in phys]))
        for p, e, w, k in zip(phys, eps_t, omega, kappa):
            block = history_block(p, offset)
            block[EPS_T] = e
            if w > 0:
                block[OMEGA], block[KAPPA] = w, k
    # contacts: made now, their stiffness and reference set by the law at their first step
    # (a step of zero length, which leaves the links above as they are), then their history
    id_of = np.full(max(old_of.max(initial=-1), links.pairs.max(initial=-1)) + 1, -1)
    id_of[old_of[old_of >= 0]] = np.asarray(ids)[old_of >= 0]
    made, kept, lost = [], [], 0
    for k in captured.values():          # (links broken and erased are not here)
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
        for i, k, sign in kept:
            _write(i, links, k, sign, offset)
    counts = {"carried": len(carry), "contacts": len(kept), "contacts_lost": lost,
              "erased": len(erase), "new": len(new)}
    return counts, [(i.id1, i.id2) for i, _, _ in new]


def link_energy(pairs):
    """(normal, shear) elastic energy of the links `pairs` (id1, id2), as the law's
    elasticEnergy() sums it: ½ |Fn|²/kn + ½ |Fs|²/ks with the forces of the last step."""
    O = import_yade().Omega()
    normal = shear = 0.0
    for a, b in pairs:
        if O.interactions.has(a, b):
            p = O.interactions[a, b].phys
            normal += 0.5 * p.normalForce.squaredNorm() / p.kn
            shear += 0.5 * p.shearForce.squaredNorm() / p.ks
    return normal, shear


def damage_history(omega, eps_crack, eps_fracture):
    """κ at which CPM's exponential softening (CpmMat.damLaw 1, the default) reaches damage
    ω: ω = 1 − (ε₀/κ) exp(−(κ − ε₀)/ε_f), increasing in κ (verified against YADE's links);
    0 where ω = 0. Bisection, to the last bit in 200 halvings."""
    omega = np.asarray(omega, float)
    low, high = np.array(eps_crack, float), np.array(eps_crack, float)
    law = lambda k: 1 - eps_crack / k * np.exp(-(k - eps_crack) / eps_fracture)
    while (law(high) < omega).any():
        high = np.where(law(high) < omega, 2 * high, high)
    for _ in range(200):
        mid = 0.5 * (low + high)
        below = law(mid) < omega
        low, high = np.where(below, mid, low), np.where(below, high, mid)
    return np.where(omega > 0, high, 0.0)


def _write(i, links, k, sign, offset):
    """Captured link k into the interaction i (sign -1: its bodies in the other order)."""
    values = links.history[k].copy()
    values[_VECTORS] *= sign
    history_block(i.phys, offset)[:] = values
    i.geom.normal = tuple(sign * links.normal[k])
    i.phys.G = float(links.shear_modulus[k])
    i.phys.refPD = float(links.ref_penetration[k])
    i.phys.isCohesive = bool(links.cohesive[k])


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
