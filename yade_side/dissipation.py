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
it is found is missed. The trapezoidal terms want a sample every step.
"""
import math

import numpy as np

from yade_side import import_yade
from yade_side.memory import WIDTH, HistoryBlocks, find_offset

# columns of a link's history block (yade_side.memory.HISTORY's order)
_OMEGA, _SIGMA_N, _EPS_N, _EPS_N_PL = 0, 2, 3, 6
_SIGMA_T, _EPS_T = slice(7, 10), slice(16, 19)
SAMPLE = 64     # links on which the history's place in memory is found


class LinkMeter:
    """The energy dissipated, from now on, by the CPM interactions of the scene: the links it
    has now, and the contacts that `relist` finds later. Call `sample()` after every step,
    `relist()` every few tens of steps (a walk over the interactions), `dissipated()` at the
    end."""

    def __init__(self):
        self._phys, self._keys = [], []
        self.volume, self.young, self.shear_modulus = np.empty(0), np.empty(0), np.empty(0)
        self._start = self._last = np.empty((0, WIDTH))
        self._blocks = None
        self.damage = self.shear_work = self.plastic_work = 0.0
        self.relist()
        if not self._phys:
            raise ValueError("no CPM interactions to measure")

    def relist(self):
        """Add the CPM interactions the scene has that the meter does not (each one's law must
        have run once, which sets its length and section): they count from now on. A walk over
        the interactions (~1 µs each); each is known by its pair and the step it was made real
        in."""
        O = import_yade().Omega()
        CpmPhys = import_yade().wrapper.CpmPhys
        known = set(self._keys)
        new = [i for i in O.interactions if i.isReal and _key(i) not in known
               and isinstance(i.phys, CpmPhys)]
        if not new:
            return
        phys = [i.phys for i in new]
        p = np.array([(q.crossSection, q.refLength, q.E, q.ks) for q in phys], float)
        if not np.isfinite(p).all() or (p[:, :2] <= 0).any():
            raise ValueError("an interaction's length or section is not set yet: sample after "
                             "a step")
        offset = find_offset(new, SAMPLE)
        now = HistoryBlocks(phys, offset).read()
        self._phys += phys
        self._keys += [_key(i) for i in new]
        self.volume = np.concatenate([self.volume, p[:, 0] * p[:, 1]])
        self.young = np.concatenate([self.young, p[:, 2]])
        self.shear_modulus = np.concatenate([self.shear_modulus,
                                             p[:, 3] * p[:, 1] / p[:, 0]])  # G0 = ks L0 / A
        self._start = np.concatenate([self._start, now])
        self._last = np.concatenate([self._last, now])
        self._blocks = HistoryBlocks(self._phys, offset)

    def sample(self):
        """Add the damage's dissipation and the shear and normal plastic work since the last
        sample."""
        a, b = self._last, self._blocks.read()
        self.damage += float(self.volume @ (0.5 * (self._release_rate(a) + self._release_rate(b))
                                            * (b[:, _OMEGA] - a[:, _OMEGA])))
        self.shear_work += float(self.volume @ np.einsum(
            "ij,ij->i", 0.5 * (a[:, _SIGMA_T] + b[:, _SIGMA_T]), b[:, _EPS_T] - a[:, _EPS_T]))
        self.plastic_work += float(self.volume @ (0.5 * (a[:, _SIGMA_N] + b[:, _SIGMA_N])
                                                  * (b[:, _EPS_N_PL] - a[:, _EPS_N_PL])))
        self._last = b

    def _release_rate(self, h):
        """½ E ⟨εN − εNPl⟩² per unit volume: the energy a unit of damage releases."""
        return 0.5 * self.young * np.maximum(h[:, _EPS_N] - h[:, _EPS_N_PL], 0.0) ** 2

    def _shear_energy(self, h, alive):
        """½ |σT|² V / G0 of the links `alive` (a link without shear stiffness has none)."""
        sig = h[:, _SIGMA_T]
        energy = np.divide(0.5 * self.volume * np.einsum("ij,ij->i", sig, sig),
                           self.shear_modulus, out=np.zeros(len(sig)),
                           where=self.shear_modulus > 0)
        return float(energy @ alive)

    def dissipated(self):
        """Energies (J) dissipated since each interaction joined: damage, deleted (the stored
        normal energy of the links deleted), shear, plastic, total; and how many interactions
        were measured (`measured`) and are gone (`deleted_count`)."""
        self.sample()
        h, alive = self._last, self.alive()
        deleted = float(np.sum(~alive * (1 - h[:, _OMEGA]) * self._release_rate(h)
                               * self.volume))
        shear = self.shear_work - (self._shear_energy(h, alive)
                                   - self._shear_energy(self._start, np.ones_like(alive)))
        out = dict(damage=self.damage, deleted=deleted, shear=shear, plastic=self.plastic_work)
        out["total"] = math.fsum(out.values())
        out["measured"], out["deleted_count"] = len(alive), int((~alive).sum())
        return out

    def alive(self):
        """Which of the measured interactions the scene still has (a pair that touches again
        makes another one)."""
        O = import_yade().Omega()
        now = {_key(i) for i in O.interactions if i.isReal}
        return np.array([k in now for k in self._keys], bool)


def _key(interaction):
    """An interaction's pair and the step it was made real in: YADE keeps a broken link's
    interaction while the pair's bounds overlap, and gives it a new CpmPhys (and a new step)
    when the spheres touch again."""
    return interaction.id1, interaction.id2, interaction.iterMadeReal
