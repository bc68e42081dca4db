"""The energy dissipated by cracking, per cohesive CPM link: a closed form of YADE's public CPM
law, from each link's damage history read in bulk from YADE's memory (yade_side.memory). What
an FE cell's dissipated_cells is on the FE side (fenicsx_side.damaged), so that the two can be
summed on one grid.

The law (Law2_ScGeom_CpmPhys_Cpm, pkg/dem/ConcretePM.cpp; YADE's public model, without the
rate-dependent CPM_MATERIAL_MODEL), per link: ε = εN − εNPl its elastic normal strain,
κ = kappaD the largest equivalent strain √(⟨ε⟩² + ξ² |εT|²) it has had (ξ =
equivStrainShearContrib, 0 by default), ω = 1 − (ε0/κ) exp(−(κ − ε0)/εf) for κ > ε0, else 0
(damLaw 1, exponential: YADE's default; 0, linear softening, is refused), ε0 = epsCrackOnset,
εf = epsFracture, which the law sets at the link's first step to epsCrackOnset × relDuctility
(of a link between two materials: mean ε0 × mean relDuctility), σN = (1 − ω) E ε in tension,
E ε in compression.

Damage dissipates Y dω, Y = ½ E ⟨ε⟩² (yade_side.dissipation). With ξ = 0, ω grows only while
ε = κ, so what it has dissipated depends on κ alone, whatever the path (unloading, compression,
reloading): per unit volume

    g(κ) = ∫_ε0^κ ½ E s² ω'(s) ds = W(κ) − ½ (1 − ω(κ)) E κ²,
    W(κ) = ∫_0^κ (1 − ω(s)) E s ds = ½ E ε0² + E ε0 εf (1 − e),   e = exp(−(κ − ε0)/εf),
    g(κ) = ½ E ε0² + E ε0 εf (1 − e) − ½ E ε0 κ e = −E ε0² [(r + x/2) m + (x − 1)/2],

x = κ/ε0, r = εf/ε0, m = e − 1 (expm1: no cancellation near ε0); 0 where ω = 0 (κ ≤ ε0, or
a neverDamage link, whose κ grows though ω does not). Per link × its volume crossSection ×
refLength. Towards full damage g → E ε0² (½ + r), the work to full separation, short by
E ε0 e (εf + κ/2). With ξ > 0 damage also grows under shear, where Y < ½ E κ²: g(κ) is then
an upper bound of the link's Y dω.

E and crossSection are the link's as YADE holds them: a link of the coupled model's band
carries its energy weight (crossSection × the mean β of its spheres, yade_side.weighting), so
the energy is the weighted one, what the coupled model's energy counts.

A link the law deletes (at its first step with ω > omegaThreshold, in tension) has dissipated
its envelope work W(κ) to deletion (its stored energy goes with it: dissipation.py's
`deleted`), ≈ W(κ*) at ω(κ*) = omegaThreshold (fracture.link_work_density: `at_break`, short
by at most (1 − ω(κ*)) E κ* × the strain of its last step). Given an earlier result,
link_cracking_energy keeps the links gone since at their at_break.
"""
from typing import NamedTuple

import numpy as np

from yade_side import import_yade
from yade_side.distributed import remote
from yade_side.fracture import ductility_factor
from yade_side.memory import HISTORY, WIDTH, Fields, history_offset
from yade_side.scene import cpm_law

# the CpmPhys fields read (memory.Fields); ω and κ are in the history block (memory.HISTORY)
FIELDS = ("E", "crossSection", "refLength", "epsCrackOnset", "epsFracture")
_OMEGA, _KAPPA = HISTORY.index("omega"), HISTORY.index("kappaD")
SAMPLE = 64     # links on which the history's place in memory is verified (dissipation.py's)


class LinkCracking(NamedTuple):
    """Per cohesive link: ids (n, 2) its bodies (id1, id2), energy (n,) what its damage has
    dissipated (J), at_break (n,) what it has dissipated once the law deletes it (J)."""
    ids: np.ndarray
    energy: np.ndarray
    at_break: np.ndarray


def cracking_density(young, eps0, eps_f, kappa):
    """g(κ) (J/m³): what the exponential damage of a link (or an FE cell) of modulus `young`,
    onset strain ε0 and softening strain εf has dissipated once its history reached κ; 0 up
    to ε0 (arrays broadcast)."""
    x, r = kappa / eps0, eps_f / eps0
    m = np.expm1(-(x - 1) / r)
    return np.where(x > 1, -young * eps0 ** 2 * ((r + x / 2) * m + (x - 1) / 2), 0.0)


def link_cracking_energy(before=None):
    """The scene's cohesive CPM links (isCohesive: the frictional contacts have ω = 1 and no
    crack) and what each one's damage has dissipated (LinkCracking, J; the module's g(κ) ×
    crossSection × refLength). `before`: an earlier result of the same scene, whose links the
    scene no longer has (deleted by the law) are kept, after the scene's, at their at_break;
    a link made and deleted between two calls is missed. One walk over the interactions and
    the fields in bulk: ~2 µs per link (22,000 links: 0.04 s), for output times. A scene split
    over MPI ranks is refused (its links are in the workers)."""
    if remote() is not None:
        raise ValueError("link cracking energy reads the scene of this process, not one split "
                         "over MPI ranks")
    yade = import_yade()
    O = yade.Omega()
    linear = {m.id for m in O.materials if isinstance(m, yade.wrapper.CpmMat) and m.damLaw != 1}
    if linear:
        raise ValueError(f"CpmMat {sorted(linear)} has damLaw 0 (linear softening): the closed "
                         f"form is the exponential law's")
    CpmPhys = yade.wrapper.CpmPhys
    phys, pairs = [], []
    for i in O.interactions:
        p = i.phys
        if i.isReal and isinstance(p, CpmPhys) and p.isCohesive:
            phys.append(p)
            pairs.append((i.id1, i.id2))
    ids = np.array(pairs, np.int64).reshape(-1, 2)
    now = _cracking(phys, ids)
    if before is None or not len(before.ids):
        return now
    base = int(max(ids.max(initial=0), before.ids.max())) + 1
    gone = ~np.isin(before.ids @ [base, 1], ids @ [base, 1])
    # the links deleted since, at their work to deletion
    return LinkCracking(*(np.concatenate([a, b[gone]]) for a, b in
                          zip(now, (before.ids, before.at_break, before.at_break))))


def _cracking(phys, ids):
    """LinkCracking of the CpmPhys `phys` of the links `ids`."""
    if not phys:
        return LinkCracking(ids, np.zeros(0), np.zeros(0))
    fields = Fields(phys, FIELDS)
    E, area, length, eps0, eps_f = (fields.read(name) for name in FIELDS)
    history = fields.read_block(history_offset(phys, SAMPLE), WIDTH)
    volume = area * length
    energy = np.where(history[:, _OMEGA] > 0,
                      volume * cracking_density(E, eps0, eps_f, history[:, _KAPPA]), 0.0)
    return LinkCracking(ids, energy, volume * E * eps0 ** 2 * _work_factor(eps_f / eps0))


def _work_factor(r):
    """W(κ*)/(E ε0²) of each link's r = εf/ε0 (fracture.ductility_factor, once per value) at
    the law's omegaThreshold; ½ + r, the whole work, where links are never deleted
    (omegaThreshold ≥ 1: ω never exceeds it)."""
    law = cpm_law()
    threshold = 1.0 if law is None else law.omegaThreshold
    values, where = np.unique(r, return_inverse=True)
    factor = (0.5 + values if threshold >= 1
              else np.array([ductility_factor(v, threshold) for v in values]))
    return factor[where.ravel()]
