"""An isotropic damage law for concrete, regularised by the crack band: pure numpy, per cell.

- Equivalent strain, one measure for tension and one for compression, the larger governing:
  - tension, Rankine's: the largest principal effective stress over E, ε_t = ⟨σ̄₁⟩ / E
    (σ̄ = C : ε), as in the isotropic Rankine damage model (Jirásek & Bažant, Inelastic
    Analysis of Structures, Wiley 2002, ch. 25; Jirásek, "Damage and smeared crack models",
    CISM 2011). Damage starts at ft in any state of tension;
  - compression (tr ε < 0 only), the modified von Mises strain of de Vree, Brekelmans &
    van Gils (Computers & Structures 57, 1995, 581-588), with k = fc / ft:
        ε_c = (k − 1) I₁ / (2k(1 − 2ν)) + 1/(2k) √( ((k − 1) I₁ / (1 − 2ν))² + 12 k J₂ / (1 + ν)² )
    (I₁ = tr ε, J₂ = ½ dev ε : dev ε): 1/k of the axial strain in uniaxial compression, so
    damage starts at fc; zero in hydrostatic compression. Where tr ε ≥ 0 it is left out: a
    strain measure with k ≈ 10 would start damage at 0.65 ft in tension without lateral
    contraction (a crack opening), and a bar pulled apart would dissipate 0.7-0.8 Gf.
- History κ = max over time of ε_eq (κ ≥ κ₀ = ft / E); damage, exponential softening:

      D(κ) = 1 − (κ₀ / κ) exp(−(κ − κ₀) / ε_f)        (κ > κ₀; 0 below)

  so that in uniaxial tension σ = (1 − D) E ε = ft exp(−(ε − κ₀) / ε_f) past the peak.
- Crack band (Bažant & Oh, Matériaux et Constructions 16, 1983, 155-177): a crack smeared over an
  element of width h dissipates Gf per unit area. A band inside the material opens without
  lateral strain (its neighbours unload): ε = e n⊗n, σ̄ₙₙ = M e with the constrained modulus
  M = E (1 − ν) / ((1 + ν)(1 − 2ν)), ε_eq = M e / E, and the energy it releases to full damage
  is (E / M) ft (κ₀/2 + ε_f) per unit volume. Equal to Gf / h:
      ε_f = (M / E) Gf / (h ft) − κ₀ / 2,
  which needs h < 2 M Gf / ft² (else the element would snap back). (Calibrated on uniaxial
  stress instead, an interior band would dissipate E/M = 0.9 Gf at ν = 0.2: measured on a
  bar, tests/test_fe_damage.py.) Compression softens with the same ε_f on its own measure:
  no separate compressive fracture energy.
- h: the element's width along the largest principal strain n when its damage starts,
  h = 2 / Σ_i |∇N_i · n| at the cell's centre (Oliver, IJNME 28, 1989, 461-474): the side of a
  box-shaped element along an axis, the height over a face of a tetrahedron.
"""
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ConcreteDamage:
    young: float               # E (Pa)
    poisson: float             # ν
    tensile_strength: float    # ft (Pa)
    compressive_strength: float  # fc (Pa)
    fracture_energy: float     # Gf (J/m²)

    def __post_init__(self):
        for name in ("young", "tensile_strength", "compressive_strength", "fracture_energy"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"FE damage: {name} must be a positive number, got {value!r}")
        if not -1.0 < self.poisson < 0.5:
            raise ValueError(f"FE damage: poisson must be in (-1, 0.5), got {self.poisson!r}")
        if not self.compressive_strength > self.tensile_strength:
            raise ValueError(f"FE damage: compressive_strength {self.compressive_strength!r} Pa "
                             f"must exceed tensile_strength {self.tensile_strength!r} Pa")

    @property
    def kappa0(self):
        return self.tensile_strength / self.young

    @property
    def constrained_ratio(self):
        """M / E, the constrained modulus over Young's."""
        nu = self.poisson
        return (1 - nu) / ((1 + nu) * (1 - 2 * nu))

    @property
    def max_element_size(self):
        """2 M Gf / ft²: the largest element width the crack band can regularise."""
        return (2 * self.constrained_ratio * self.young * self.fracture_energy
                / self.tensile_strength ** 2)

    def equivalent_strain(self, eps, floor=0.0):
        """ε_eq of strain tensors eps (n, 3, 3), symmetric. The principal strains are computed
        only where ε_eq can pass `floor` (a scalar or per-tensor array: what it must pass to
        matter): elsewhere the result is a bound below `floor`."""
        nu = self.poisson
        k = self.compressive_strength / self.tensile_strength
        lam_e = nu / ((1 + nu) * (1 - 2 * nu))          # λ / E, and 2μ / E = 1 / (1 + ν)
        i1 = np.trace(eps, axis1=1, axis2=2)
        dev = eps - i1[:, None, None] * np.eye(3) / 3
        j2 = 0.5 * np.einsum("cab,cab->c", dev, dev)
        a = (k - 1) * i1 / (1 - 2 * nu)
        compression = np.where(i1 < 0, (a + np.sqrt(a * a + 12 * k * j2 / (1 + nu) ** 2))
                               / (2 * k), 0.0)
        # ε₁ ≤ |ε|: the tension measure needs eigenvalues only where its bound passes floor
        bound = lam_e * i1 + np.sqrt(2 * j2 + i1 * i1 / 3) / (1 + nu)
        tension = np.maximum(bound, 0.0)
        near = np.flatnonzero(bound > floor)
        if near.size:
            e1 = largest_eigenvalue(eps[near])
            tension[near] = np.maximum(lam_e * i1[near] + e1 / (1 + nu), 0.0)
        return np.maximum(tension, compression)

    def softening_strain(self, h):
        """ε_f of elements of width h (array, m); ValueError if one is too wide."""
        h = np.asarray(h, float)
        wide = np.flatnonzero(h >= self.max_element_size)
        if wide.size:
            raise ValueError(f"FE damage: an element {h.flat[wide[0]]:.4g} m wide is beyond the "
                             f"crack band's limit 2 M Gf / ft² = {self.max_element_size:.4g} m "
                             f"(E {self.young:.4g} Pa, Gf {self.fracture_energy:.4g} J/m², ft "
                             f"{self.tensile_strength:.4g} Pa): refine the mesh")
        return (self.constrained_ratio * self.fracture_energy / (h * self.tensile_strength)
                - 0.5 * self.kappa0)

    def damage(self, kappa, eps_f):
        """D(κ) for histories kappa and softening strains eps_f (arrays of one shape)."""
        kappa = np.asarray(kappa, float)
        k0 = self.kappa0
        above = kappa > k0
        out = np.zeros_like(kappa)
        kk, ef = kappa[above], np.broadcast_to(eps_f, kappa.shape)[above]
        out[above] = 1.0 - (k0 / kk) * np.exp(-(kk - k0) / ef)
        return out


def largest_eigenvalue(a):
    """The largest eigenvalue of symmetric 3 × 3 matrices a (n, 3, 3), in closed form (the
    trigonometric solution of the characteristic cubic: Smith, CACM 4, 1961, 168)."""
    q = np.trace(a, axis1=1, axis2=2) / 3
    b = a - q[:, None, None] * np.eye(3)
    p = np.sqrt(np.einsum("cab,cab->c", b, b) / 6)
    c = b / np.where(p > 0, p, 1.0)[:, None, None]
    (c00, c01, c02), (c11, c12, c22) = (c[:, 0, k] for k in range(3)), (c[:, 1, 1], c[:, 1, 2],
                                                                         c[:, 2, 2])
    r = (c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02)
         + c02 * (c01 * c12 - c11 * c02)) / 2
    phi = np.arccos(np.clip(r, -1.0, 1.0)) / 3
    return q + 2 * p * np.cos(phi)


def band_width(gradients, direction):
    """Oliver's element width 2 / Σ_i |∇N_i · n| for cells with shape-function gradients at
    their centres (n, nv, 3) and unit directions (n, 3)."""
    return 2.0 / np.abs(np.einsum("cia,ca->ci", gradients, direction)).sum(axis=1)
