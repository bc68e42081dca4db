"""The energy CPM links dissipate, measured on the links themselves: not the remainder of an
energy balance, so that the balance of a test (work in = elastic + kinetic + damping +
dissipated) can be checked.

Per cohesive link of volume V = A L0 (crossSection × refLength), under YADE's public CPM law
(ConcretePM.cpp), whose damage ω softens the tensile normal stress only
(σN = (1 − ω) E ε in tension, ε = εN − εNPl), whatever the damage law and the shear's share ξ
of the equivalent strain:
- damage: the normal work less the change of the stored ½ (1 − ω) E ⟨ε⟩² V is
  ½ E ⟨ε⟩² V dω, the energy release rate times the damage increment (trapezoidal between
  samples);
- a link deleted (ω past the law's omegaThreshold) takes its stored energy with it:
  ½ (1 − ω) E ⟨ε⟩² V from its last state, which its CpmPhys keeps (the meter holds it);
- shear: the work of the shear stress on the shear strain, σT · dεT V (trapezoidal), less the
  change of its stored energy ½ |σT|² V / G0 (G0 = ks L0 / A, as YADE's elasticEnergy
  counts it): the slip of the Mohr-Coulomb return, and the shear a cracked link loses when
  released (G = 0, yade_side.scene.release_cracked_shear) or deleted;
- normal plastic strain (the law's compression softening, off unless epsSoft < 0):
  σN dεNPl V (trapezoidal).
Contacts made later (frictional, not cohesive: ω = 1, Coulomb's friction only) join the meter
when it lists the scene's interactions again (`LinkMeter.relist`); what one dissipates before
it is found is missed. The trapezoidal terms want a sample every step, or every few (the
caller measures what that costs it).
"""
import math

import numpy as np

from yade_side import import_yade
from yade_side.memory import HistoryBlocks, find_offset

# the columns of a link's history block read (yade_side.memory.HISTORY's order), and where
# each quantity is among them
COLUMNS = (0, 2, 3, 6, 7, 8, 9, 16, 17, 18)
_OMEGA, _SIGMA_N, _EPS_N, _EPS_N_PL = 0, 1, 2, 3
_SIGMA_T, _EPS_T = slice(4, 7), slice(7, 10)
SAMPLE = 64     # links on which the history's place in memory is found
BATCHES = 16    # reads of the interactions found by successive searches, before one of all


class LinkMeter:
    """The energy dissipated, from now on, by the CPM interactions of the scene: the links it
    has now, and the contacts that `relist` finds later; per interaction, so that a caller
    can split it by place (`keys`: each one's pair and the step it was made real in). Call
    `sample()` after every step (or few), `relist()` as often as contacts come and go (a walk
    over the interactions), `dissipated()` at the end."""

    def __init__(self):
        self._phys, self._keys = [], np.empty((0, 3), np.int64)
        # the step of the last search (newer interactions are new), and the keys found made
        # real at that step, which the next search sees again
        self._listed_at, self._recent = -1, set()
        self.volume, self.young, self.shear_modulus = np.empty(0), np.empty(0), np.empty(0)
        self._last = np.empty((0, len(COLUMNS)))
        self._start_shear = np.empty(0)     # each one's stored shear energy when it joined
        self._batches, self._offset = [], None
        # per interaction, since it joined: the damage's dissipation, the shear and the
        # normal plastic work
        self._damage, self._shear, self._plastic = np.empty(0), np.empty(0), np.empty(0)
        self.relist()
        if not self._phys:
            raise ValueError("no CPM interactions to measure")

    @property
    def keys(self):
        """(n, 3) int: each measured interaction's id1, id2 and the step it was made real in."""
        return self._keys

    damage = property(lambda self: float(self._damage.sum()))
    shear_work = property(lambda self: float(self._shear.sum()))
    plastic_work = property(lambda self: float(self._plastic.sum()))

    def relist(self):
        """Add the CPM interactions the scene has that the meter does not (each one's law must
        have run once, which sets its length and section): they count from now on. A walk over
        the interactions that reads only when each was made real (~0.3 µs each): those made
        since the last walk are looked at; each is known by its pair and that step. Returns
        how many it added."""
        O = import_yade().Omega()
        CpmPhys = import_yade().wrapper.CpmPhys
        since, self._listed_at = self._listed_at, O.iter
        new = [i for i in O.interactions if i.iterMadeReal >= since and i.isReal
               and isinstance(i.phys, CpmPhys) and _key(i) not in self._recent]
        keys = [_key(i) for i in new]
        self._recent = {k for k in self._recent | set(keys) if k[2] >= self._listed_at}
        if not new:
            return 0
        phys = [i.phys for i in new]
        p = np.array([(q.crossSection, q.refLength, q.E, q.ks) for q in phys], float)
        if not np.isfinite(p).all() or (p[:, :2] <= 0).any():
            raise ValueError("an interaction's length or section is not set yet: sample after "
                             "a step")
        self._offset = find_offset(new, SAMPLE)
        now = HistoryBlocks(phys, self._offset, COLUMNS).read()
        zeros = np.zeros(len(new))
        rows = np.arange(len(self._phys), len(self._phys) + len(new))
        self._phys += phys
        self._keys = np.concatenate([self._keys, np.array(keys, np.int64)])
        volume, shear_modulus = p[:, 0] * p[:, 1], p[:, 3] * p[:, 1] / p[:, 0]  # G0 = ks L0 / A
        self.volume = np.concatenate([self.volume, volume])
        self.young = np.concatenate([self.young, p[:, 2]])
        self.shear_modulus = np.concatenate([self.shear_modulus, shear_modulus])
        self._start_shear = np.concatenate([self._start_shear,
                                            _shear_energy(now, volume, shear_modulus)])
        self._last = np.concatenate([self._last, now])
        self._damage, self._shear, self._plastic = (np.concatenate([a, zeros]) for a in
                                                    (self._damage, self._shear, self._plastic))
        if len(self._batches) >= BATCHES:
            self._bind()
        else:
            self._batches.append((rows, HistoryBlocks(phys, self._offset, COLUMNS)))
        return len(new)

    def _bind(self):
        """One read of every interaction that has a CpmPhys here (those a reloaded scene no
        longer has keep their last values)."""
        rows = np.array([k for k, p in enumerate(self._phys) if p is not None], int)
        self._batches = [(rows, HistoryBlocks([self._phys[k] for k in rows], self._offset,
                                              COLUMNS))]

    def _read(self):
        (rows, blocks), *more = self._batches
        if not more and len(rows) == len(self._last):
            return blocks.read()
        out = self._last.copy()
        for rows, blocks in self._batches:
            out[rows] = blocks.read()
        return out

    _ARRAYS = ("volume", "young", "shear_modulus", "_start_shear", "_last", "_damage",
               "_shear", "_plastic")

    def state(self):
        """What a checkpoint keeps ({name: array}): restored() carries on from it."""
        return {"keys": self.keys, "listed_at": np.array(self._listed_at),
                **{name.lstrip("_"): getattr(self, name) for name in self._ARRAYS}}

    @classmethod
    def restored(cls, state):
        """The meter whose state() a checkpoint kept, on the scene reloaded from it: the
        interactions the scene still has are read on, those gone keep what they had. A state
        of an earlier version (each one's history block at its start, no search step) is read
        too: its next search looks at every interaction."""
        O = import_yade().Omega()
        meter = cls.__new__(cls)
        meter._keys = np.asarray(state["keys"], np.int64).reshape(-1, 3)
        meter._listed_at = int(state.get("listed_at", -1))
        if "start" in state:        # the earlier version's
            state = {**state, "start_shear": _shear_energy(
                np.asarray(state["start"], float), np.asarray(state["volume"], float),
                np.asarray(state["shear_modulus"], float))}
        for name in cls._ARRAYS:
            setattr(meter, name, np.array(state[name.lstrip("_")], float))
        keys = [tuple(int(v) for v in k) for k in meter._keys]
        meter._recent = {k for k in keys if k[2] >= meter._listed_at}
        scene = {_key(i): i for i in O.interactions if i.isReal}
        found = [scene.get(k) for k in keys]
        meter._phys = [None if i is None else i.phys for i in found]
        meter._offset = find_offset([i for i in found if i is not None], SAMPLE)
        meter._bind()
        return meter

    def sample(self):
        """Add the damage's dissipation and the shear and normal plastic work since the last
        sample."""
        a, b = self._last, self._read()
        self._damage += self.volume * (0.5 * (self._release_rate(a) + self._release_rate(b))
                                       * (b[:, _OMEGA] - a[:, _OMEGA]))
        self._shear += self.volume * np.einsum(
            "ij,ij->i", 0.5 * (a[:, _SIGMA_T] + b[:, _SIGMA_T]), b[:, _EPS_T] - a[:, _EPS_T])
        self._plastic += self.volume * (0.5 * (a[:, _SIGMA_N] + b[:, _SIGMA_N])
                                        * (b[:, _EPS_N_PL] - a[:, _EPS_N_PL]))
        self._last = b

    def _release_rate(self, h):
        """½ E ⟨εN − εNPl⟩² per unit volume: the energy a unit of damage releases."""
        return 0.5 * self.young * np.maximum(h[:, _EPS_N] - h[:, _EPS_N_PL], 0.0) ** 2

    def _shear_energy(self, h):
        return _shear_energy(h, self.volume, self.shear_modulus)

    def stored(self, alive):
        """The elastic energy each interaction holds at the last sample (J), ½ V (σN (εN − εNPl)
        + |σT|² / G0): the law's stresses are secant (σN = (1 − ω) E ε in tension, E ε in
        compression), so this is what unloading gives back; 0 for those not `alive`."""
        h = self._last
        normal = 0.5 * self.volume * h[:, _SIGMA_N] * (h[:, _EPS_N] - h[:, _EPS_N_PL])
        return np.where(alive, normal + self._shear_energy(h), 0.0)

    def per_interaction(self, alive):
        """{"damage", "shear", "plastic"}: what each interaction has dissipated since it
        joined (J), the shear less the change of its stored shear energy (a link gone, or
        released, has lost its own); `alive`: alive()'s mask."""
        shear = self._shear - (np.where(alive, self._shear_energy(self._last), 0.0)
                               - self._start_shear)
        return {"damage": self._damage, "shear": shear, "plastic": self._plastic}

    def dissipated(self):
        """Energies (J) dissipated since each interaction joined: damage, deleted (the stored
        normal energy of the links deleted), shear, plastic, total; and how many interactions
        were measured (`measured`) and are gone (`deleted_count`)."""
        self.sample()
        h, alive = self._last, self.alive()
        deleted = float(np.sum(~alive * (1 - h[:, _OMEGA]) * self._release_rate(h)
                               * self.volume))
        parts = self.per_interaction(alive)
        out = dict(damage=self.damage, deleted=deleted, shear=float(parts["shear"].sum()),
                   plastic=self.plastic_work)
        out["total"] = math.fsum(out.values())
        out["measured"], out["deleted_count"] = len(alive), int((~alive).sum())
        return out

    def alive(self):
        """Which of the measured interactions the scene still has (a pair that touches again
        makes another one)."""
        O = import_yade().Omega()
        now = np.array([_key(i) for i in O.interactions if i.isReal], np.int64).reshape(-1, 3)
        return np.isin(_rows(self._keys), _rows(now))


def _rows(keys):
    """Each row of an (n, 3) int array as one value, for set operations on rows."""
    keys = np.ascontiguousarray(keys, np.int64)
    return keys.view(np.dtype((np.void, keys.dtype.itemsize * 3))).ravel()


def _shear_energy(h, volume, shear_modulus):
    """½ |σT|² V / G0 per interaction of the history columns `h` (one without shear stiffness
    has none)."""
    sig = h[:, _SIGMA_T]
    return np.divide(0.5 * volume * np.einsum("ij,ij->i", sig, sig), shear_modulus,
                     out=np.zeros(len(sig)), where=shear_modulus > 0)


def _key(interaction):
    """An interaction's pair and the step it was made real in: YADE keeps a broken link's
    interaction while the pair's bounds overlap, and gives it a new CpmPhys (and a new step)
    when the spheres touch again."""
    return interaction.id1, interaction.id2, interaction.iterMadeReal
