"""The fit of the CPM micro-parameters to a target E, ν, fc (and fracture energy), from the
uniaxial tests of yade_side.calibration and the separation test of yade_side.fracture.

The fit rests on the CPM law being positively homogeneous (checked in tests/test_calibration.py):
- young and sigmaT × μ (epsCrackOnset fixed: link tensile strength E_c ε0 × μ): every stress × μ
  at the same strains, so E, fc, ft × μ and ν unchanged;
- sigmaT and epsCrackOnset × λ (young fixed): the link law becomes σ'(λε) = λσ(ε) (damage
  ω(κ) = 1 − (ε0/κ) exp(−(κ − ε0)/εf) with εf = relDuctility·ε0 is a function of κ/ε0), so fc and
  ft × λ with E unchanged.
The first is exact (with density × μ too the motion is the same); the second only
quasi-statically: hence a few iterations.
"""
import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from yade_side import fracture
from yade_side.calibration import Loading, uniaxial_test
from yade_side.material import ConcreteParams


@dataclass
class Target:
    young: float = 31e9
    compressive_strength: float = 31e6
    poisson: float = None          # None: keep CpmMat.poisson, only report ν
    density: float = 2400.0
    fracture_energy: float = None  # J/m²; None: keep relDuctility (and ft from a tension test)

    def __post_init__(self):
        for name in ("young", "compressive_strength", "density"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"target {name} must be a positive number, got {v!r}")
        gf = self.fracture_energy
        if gf is not None and not (gf > 0 and math.isfinite(gf)):
            raise ValueError(f"target fracture_energy must be a positive number (J/m²), "
                             f"got {gf!r}")
        if self.poisson is not None and not 0 < self.poisson < 0.25:
            raise ValueError(f"target poisson must be in (0, 0.25) (sphere packings with "
                             f"shear links reach ν < 1/4), got {self.poisson!r}")


def _next_link_ratio(history, nu_target):
    """Secant step on CpmMat.poisson α (shear/normal link stiffness) towards ν; with one point,
    the slope of the random-packing estimate ν = (1 − α)/(4 + α) (Liao et al. 1997),
    dν/dα = −5/(4 + α)². The step stays within [α/2, 2α]."""
    (a1, n1) = history[-1]
    slope = -5.0 / (4.0 + a1) ** 2
    if len(history) > 1 and history[-2][0] != a1:
        a0, n0 = history[-2]
        slope = (n1 - n0) / (a1 - a0) if n1 != n0 else slope
    return float(np.clip(a1 + (nu_target - n1) / slope, a1 / 2, 2 * a1))


def calibrate(sample, target, params=None, loading=Loading(), tol=0.02, nu_tol=0.01,
              gf_tol=0.05, max_iter=6, log=print):
    """Fit young, sigmaT, epsCrackOnset (and poisson, relDuctility if targeted) so that the
    compression test gives target E, fc (ν) within tol (nu_tol) and the separation test
    (yade_side.fracture) the target fracture energy within gf_tol; each iteration runs both
    tests. Without a fracture energy target, a tension test gives ft once E and fc fit.
    If the Gf target needs a relDuctility beyond its bounds, r stays at the bound and the fit
    goes on for E and fc (converged: False). Returns dict(params, compression, tension,
    iterations=[...], converged); `tension` is the separation test when Gf is fitted."""
    params = replace(params or ConcreteParams(), density=target.density)
    fit_gf = target.fracture_energy is not None
    iterations, converged, gf_out_of_reach = [], False, False
    for it in range(1, max_iter + 1):
        c = uniaxial_test(sample, params, "compression", loading)
        fc = -c["peak"]
        record = dict(params=asdict(params), E=c["E"], nu=c["nu"], fc=fc, seconds=c["seconds"])
        line = (f"iteration {it}: young={params.young:.4g} sigmaT={params.sigmaT:.4g} "
                f"epsCrackOnset={params.epsCrackOnset:.4g} poisson={params.poisson:.3g} "
                f"relDuctility={params.relDuctility:.4g} "
                f"xi={params.equivStrainShearContrib:.3g} -> E={c['E'] / 1e9:.2f} GPa "
                f"nu={c['nu']:.3f} fc={fc / 1e6:.2f} MPa")
        if fit_gf:
            t = fracture.separation_test(sample, params, loading)
            if t["fracture_energy"] is None:
                raise ValueError(f"iteration {it}, separation test: {t['balance']}")
            record.update(ft=t["peak"], fracture_energy=t["fracture_energy"],
                          seconds=c["seconds"] + t["seconds"])
            line += (f" ft={t['peak'] / 1e6:.2f} MPa Gf={t['fracture_energy']:.1f} J/m² "
                     f"(balance closed to {100 * t['closure']:+.1f} %)"
                     f"{'' if t['separated'] else ' (NOT separated)'}")
        iterations.append(record)
        log(f"{line} ({record['seconds']:.1f} s)")
        mu = target.young / c["E"]
        lam = target.compressive_strength / (mu * fc)
        nu_ok = target.poisson is None or abs(c["nu"] - target.poisson) <= nu_tol
        gf_ok = not fit_gf or abs(t["fracture_energy"] / target.fracture_energy - 1) <= gf_tol
        strength_ok = abs(mu - 1) <= tol and abs(mu * lam - 1) <= tol and nu_ok
        converged = strength_ok and gf_ok
        if converged or (strength_ok and gf_out_of_reach):
            break
        if it == max_iter:
            log(f"not converged after {max_iter} iterations")
            break
        ductility = params.relDuctility
        if fit_gf and not gf_out_of_reach:
            history = [(i["params"]["relDuctility"], i["fracture_energy"]
                        / (i["params"]["young"] * i["params"]["epsCrackOnset"] ** 2))
                       for i in iterations]
            ductility = fracture.next_ductility(history, target.fracture_energy / (
                params.young * mu * (params.epsCrackOnset * lam) ** 2))
            if ductility is None:     # keep the bound, go on fitting E and fc
                gf_out_of_reach, ductility = True, params.relDuctility
                log(f"fracture energy {target.fracture_energy:.4g} J/m² out of reach by "
                    f"relDuctility (at its bound {params.relDuctility:.4g}): fitting E, fc only")
        if not nu_ok:
            history = [(i["params"]["poisson"], i["nu"]) for i in iterations]
            params = replace(params, poisson=_next_link_ratio(history, target.poisson))
        params = replace(params, young=params.young * mu, sigmaT=params.sigmaT * mu * lam,
                         epsCrackOnset=params.epsCrackOnset * lam, relDuctility=ductility)
    if not fit_gf:
        t = uniaxial_test(sample, params, "tension", loading)
    return dict(params=asdict(params), compression=c, tension=t, iterations=iterations,
                converged=converged)
