"""Damage per sphere = broken / initial cohesive links (the paper's measure).

Not YADE's numBrokenCohesive (it also counts separating frictional contacts) nor normDmg
(smeared). Cohesive links are only made on the first step (scene.cpm_engines), so the
intact cohesive interactions are a subset of the initial ones. A link counts as broken once
its CPM damage ω reaches BROKEN_OMEGA, where YADE deletes it (scene.cpm_engines).
Walking O.interactions costs ~1 µs per entry: call update() every few hundred steps.
"""
import numpy as np

from yade_side import import_yade
from yade_side.distributed import remote
from yade_side.scene import BROKEN_OMEGA

EXCLUDED = -2        # LinkDamage's index of a sphere whose links are not counted


class LinkDamage:
    def __init__(self, ids, exclude=()):
        """ids: the spheres whose damage is measured; links with an end among `exclude` (e.g.
        the steel of reinforcement bars) are no links of theirs. Call record_initial() once
        the cohesive links exist (after create_cohesive_links)."""
        self.ids = np.asarray(ids, dtype=int)
        exclude = np.asarray(exclude, dtype=int)
        self._index = np.full(max(self.ids.max(), exclude.max(initial=0)) + 1, -1)
        self._index[self.ids] = np.arange(len(self.ids))
        self._index[exclude] = EXCLUDED
        self.initial = np.zeros(len(self.ids), int)
        self._links = np.empty((0, 2), int)

    def record_initial(self, links=None):
        """The initial links: the scene's cohesive ones now, or `links` ((m, 2) ids: those
        of a DE zone grown in place, some broken since they were made)."""
        self._links = (self._cohesive_links(require_intact=False) if links is None
                       else self._kept(np.asarray(links, int).reshape(-1, 2)))
        self.initial = self._count(self._links)
        return self.initial

    @property
    def links(self):
        """(m, 2) ids of the initial links."""
        return self._links

    def _cohesive_links(self, require_intact):
        pairs, omega = cohesive_interactions()
        if require_intact:
            pairs = pairs[omega < BROKEN_OMEGA]
        return self._kept(pairs)

    def _kept(self, pairs):
        """The pairs with no excluded end."""
        ends = np.where(pairs < len(self._index), pairs, 0)
        return pairs[~np.any((self._index[ends] == EXCLUDED) & (pairs < len(self._index)), axis=1)]

    def _count(self, links):
        counts = np.zeros(len(self.ids), int)
        for column in self._local(links).T:
            np.add.at(counts, column[column >= 0], 1)
        return counts

    def intact(self):
        """Per sphere, how many of its initial links are still intact."""
        return self._count(self._cohesive_links(require_intact=True))

    def update(self):
        """Damage per sphere in [0, 1]; 0 for spheres that had no link."""
        broken = self.initial - self.intact()
        return np.divide(broken, self.initial, out=np.zeros(len(self.ids)),
                         where=self.initial > 0)

    def link_omega(self):
        """(pairs, omega) of the initial links of the measured spheres: pairs (n, 2) the
        indices of their two spheres in `ids` (-1 for an end that is not measured), omega their
        CPM damage ω now, a broken link (ω >= BROKEN_OMEGA: deleted, or about to be) counting
        as 1; one walk over O.interactions."""
        now, now_omega = cohesive_interactions()
        local = self._local(self._links)
        mine = (local >= 0).any(axis=1)
        links = self._links[mine]
        # a link is its sorted pair of ids, as one integer; every link now was an initial one
        base = int(max(links.max(initial=0), now.max(initial=0))) + 1
        key = lambda pairs: np.sort(pairs, axis=1) @ np.array([base, 1])
        order = np.argsort(key(links))
        at = np.searchsorted(key(links)[order], key(now))
        found = at < len(links)
        found[found] &= key(links)[order][at[found]] == key(now[found])
        omega = np.ones(len(links))
        omega[order[at[found]]] = now_omega[found]
        omega[omega >= BROKEN_OMEGA] = 1.0
        return local[mine], omega

    def _local(self, pairs):
        """Indices in `ids` of the bodies of `pairs` (-1: not measured, EXCLUDED)."""
        local = np.full(pairs.shape, -1)
        inside = pairs < len(self._index)
        local[inside] = self._index[pairs[inside]]
        return local

    def worst_link(self):
        """Per sphere, the largest damage ω of its initial links, a broken one counting as 1;
        one walk over O.interactions."""
        pairs, omega = self.link_omega()
        worst = np.zeros(len(self.ids))
        for column in pairs.T:
            np.maximum.at(worst, column[column >= 0], omega[column >= 0])
        return worst

    def broken_links(self):
        """Total broken links (each counted once)."""
        return int(len(self._links) - len(self._cohesive_links(require_intact=True)))


def cohesive_interactions():
    """(pairs (n, 2) of body ids, omega (n,)) of the scene's cohesive interactions now: one walk
    over O.interactions, or over each MPI rank's (yade_side.distributed)."""
    if remote() is not None:
        return remote().links()
    pairs, omega = [], []
    for i in import_yade().Omega().interactions:
        phys = i.phys
        if phys is not None and phys.isCohesive:
            pairs.append((i.id1, i.id2))
            omega.append(phys.omega)
    return np.array(pairs, int).reshape(-1, 2), np.array(omega, float)


def _links_and_midpoints():
    """The scene's cohesive links and their midpoints (initial positions, State.refPos)."""
    O = import_yade().Omega()
    links = [i for i in O.interactions if i.isReal and i.phys.isCohesive]
    ref = np.array([[O.bodies[i.id1].state.refPos, O.bodies[i.id2].state.refPos]
                    for i in links]).reshape(-1, 2, 3)
    return links, ref.mean(axis=1)


def keep_links_elastic(outside):
    """CpmPhys.neverDamage on every cohesive link whose midpoint satisfies outside(points)
    ((n, 3) initial positions): those links never damage. Returns their number."""
    links, mid = _links_and_midpoints()
    chosen = np.flatnonzero(outside(mid))
    for k in chosen:
        links[k].phys.neverDamage = True
    return len(chosen)
