"""A concrete damage law with crack closure, regularised by the crack band, per cell (its loops
over the cells in C: fenicsx_side.kernels).

- Two damages act on the two signs of the effective stress σ̄ = C : ε (the spectral split of
  Faria, Oliver & Cervera, IJSS 35, 1998, 1533-1558; Wu, Li & Faria, IJSS 43, 2006, 583-612;
  the stiffness recovery of Lee & Fenves, J. Eng. Mech. 124, 1998, 892-900):

      σ = (1 − D_t) σ̄⁺ + (1 − D_c) σ̄⁻,   σ̄± the positive / negative spectral parts of σ̄.

  A crack (D_t) carries nothing in tension and closes in compression: a cell cracked in
  tension and then compressed uniaxially is as stiff as before (σ̄⁺ = 0), as a CPM link is
  (`sigmaN = (1 − (epsN > 0 ? omega : 0)) E epsN` in YADE's ConcretePM.cpp). Compression
  failure has its own damage D_c.
- Equivalent strains, each driving its own damage:
  - tension, Rankine's: the largest principal effective stress over E, ε_t = ⟨σ̄₁⟩ / E
    (Jirásek & Bažant, Inelastic Analysis of Structures, Wiley 2002, ch. 25). Damage starts at
    ft in any state of tension;
  - compression (tr ε < 0 only), the modified von Mises strain of de Vree, Brekelmans &
    van Gils (Computers & Structures 57, 1995, 581-588), with k = fc / ft:
        ε_c = (k − 1) I₁ / (2k(1 − 2ν)) + 1/(2k) √( ((k − 1) I₁ / (1 − 2ν))² + 12 k J₂ / (1 + ν)² )
    (I₁ = tr ε, J₂ = ½ dev ε : dev ε): 1/k of the axial strain in uniaxial compression, so
    damage starts at fc; zero in hydrostatic compression.
- Histories κ_t, κ_c = the largest ε_t, ε_c so far (κ₀ = ft / E for both); damage,
  exponential softening, each with its own ε_f:

      D(κ) = 1 − (κ₀ / κ) exp(−(κ − κ₀) / ε_f)        (κ > κ₀; 0 below)

  so that past the peak σ = ft exp(−(ε − κ₀) / ε_f) in uniaxial tension and
  |σ| = fc exp(−(|ε|/k − κ₀) / ε_fc) in uniaxial compression.
- Crack band (Bažant & Oh, Matériaux et Constructions 16, 1983, 155-177): a band of width h
  dissipates a fracture energy per unit area whatever the mesh.
  - Tension: a band inside the material opens without lateral strain (its neighbours unload):
    ε = e n⊗n, σ̄ₙₙ = M e with the constrained modulus M = E (1 − ν) / ((1 + ν)(1 − 2ν)),
    ε_t = M e / E; the energy to full damage is (E / M) ft (κ₀/2 + ε_f) per unit volume. Equal
    to Gf / h: ε_f = (M / E) Gf / (h ft) − κ₀ / 2, which needs h < 2 M Gf / ft².
  - Compression, calibrated in uniaxial compression (the specimen's test): the energy to full
    damage is fc² / 2E + k fc ε_fc per unit volume. Equal to Gc / h:
    ε_fc = (Gc / (h fc) − fc / 2E) / k, which needs h < 2 E Gc / fc².
  A wider element would snap back: refused, with its size.
- The energy the damages dissipate is Y_t dD_t + Y_c dD_c, Y± = ½ σ̄± : ε ≥ 0 (Wu, Li & Faria),
  whose sum is the elastic energy ½ σ̄ : ε.
- h: the element's width along the principal strain that starts the damage (the largest for
  tension, the most compressive for compression), h = 2 / Σ_i |∇N_i · n| at the cell's centre
  (Oliver, IJNME 28, 1989, 461-474): the side of a box-shaped element along an axis, the
  height over a face of a tetrahedron.
"""
from dataclasses import dataclass

import numpy as np

from fenicsx_side.kernels import contiguous, library

# Symmetric tensors are handled as their six components, component-major (6, n): xx, yy, zz,
# yz, xz, xy (tensor components, not engineering shears), so that the law's algebra runs on
# whole contiguous arrays of cells.
PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


@dataclass(frozen=True)
class ConcreteDamage:
    young: float               # E (Pa)
    poisson: float             # ν
    tensile_strength: float    # ft (Pa)
    compressive_strength: float  # fc (Pa)
    fracture_energy: float     # Gf (J/m²), tension
    compressive_fracture_energy: float  # Gc (J/m²), compression

    def __post_init__(self):
        for name in ("young", "tensile_strength", "compressive_strength", "fracture_energy",
                     "compressive_fracture_energy"):
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
    def strength_ratio(self):
        """k = fc / ft."""
        return self.compressive_strength / self.tensile_strength

    @property
    def constrained_ratio(self):
        """M / E, the constrained modulus over Young's."""
        nu = self.poisson
        return (1 - nu) / ((1 + nu) * (1 - 2 * nu))

    @property
    def max_element_size(self):
        """2 M Gf / ft²: the largest element width the tension crack band can regularise."""
        return (2 * self.constrained_ratio * self.young * self.fracture_energy
                / self.tensile_strength ** 2)

    @property
    def max_compressive_element_size(self):
        """2 E Gc / fc²: the largest element width the compression band can regularise."""
        return 2 * self.young * self.compressive_fracture_energy / self.compressive_strength ** 2

    def tension_strain(self, eps, floor=0.0):
        """ε_t = ⟨σ̄₁⟩ / E of strains eps (6, n). The principal strains are computed only where
        ε_t can pass `floor` (a scalar or per-cell array: what it must pass to matter), by the
        bound ε₁ ≤ tr ε / 3 + √(2/3) |dev ε|: elsewhere the result is that bound (≥ 0), below
        `floor`."""
        nu = self.poisson
        eps = contiguous(eps)
        n = eps.shape[1]
        floor = np.ascontiguousarray(np.broadcast_to(np.asarray(floor, float), (n,)))
        out = np.empty(n)
        library().tension_strain(n, eps, floor, nu / ((1 + nu) * (1 - 2 * nu)), nu, out)
        return out

    def compression_strain(self, eps):
        """ε_c of strains eps (6, n): de Vree's measure where tr ε < 0, else 0."""
        eps = contiguous(eps)
        out = np.empty(eps.shape[1])
        library().compression_strain(eps.shape[1], eps, self.strength_ratio, self.poisson, out)
        return out

    def softening_strain(self, h):
        """ε_f in tension of elements of width h (array, m); ValueError if one is too wide."""
        _check_width(h, self.max_element_size, "tension", "M Gf / ft²", "Gf",
                     self.fracture_energy, self.tensile_strength, self.young)
        return (self.constrained_ratio * self.fracture_energy / (np.asarray(h, float)
                                                                  * self.tensile_strength)
                - 0.5 * self.kappa0)

    def compressive_softening_strain(self, h):
        """ε_fc in compression of elements of width h (array, m); ValueError if one is too
        wide."""
        _check_width(h, self.max_compressive_element_size, "compression", "E Gc / fc²", "Gc",
                     self.compressive_fracture_energy, self.compressive_strength, self.young)
        fc, E = self.compressive_strength, self.young
        return (self.compressive_fracture_energy / (np.asarray(h, float) * fc)
                - 0.5 * fc / E) / self.strength_ratio

    def damage(self, kappa, eps_f):
        """D(κ) for histories kappa and softening strains eps_f (arrays of one shape)."""
        kappa = np.asarray(kappa, float)
        eps_f = np.ascontiguousarray(np.broadcast_to(np.asarray(eps_f, float), kappa.shape))
        out = np.empty(kappa.shape)
        library().damage(kappa.size, np.ascontiguousarray(kappa), eps_f, self.kappa0, out)
        return out

    def effective_stress(self, eps):
        """σ̄ = C : ε of strains (6, n)."""
        nu, E = self.poisson, self.young
        sig = (E / (1 + nu)) * eps
        sig[:3] += (E * nu / ((1 + nu) * (1 - 2 * nu))) * trace(eps)
        return sig

    def stress(self, eps, d_t, d_c):
        """σ = (1 − D_t) σ̄⁺ + (1 − D_c) σ̄⁻ of strains (6, n)."""
        sig = self.effective_stress(eps)
        pos = positive_part(sig)
        return (1 - np.asarray(d_t)) * pos + (1 - np.asarray(d_c)) * (sig - pos)

    def compaction(self, eps, d_c):
        """D_c C⁻¹ σ̄⁻ of strains (6, n): the strain the compression damage has taken out of
        the stress, C : (ε − this) = σ̄ − D_c σ̄⁻ (what is left once the tension part is
        undamaged). A material that unloads elastically from a crushed state keeps it as its
        plastic strain."""
        sig = self.effective_stress(eps)
        neg = sig - positive_part(sig)
        nu = self.poisson
        out = (1 + nu) * neg
        out[:3] -= nu * trace(neg)
        return np.asarray(d_c) / self.young * out


def _check_width(h, limit, sign, formula, name, energy, strength, young):
    h = np.asarray(h, float)
    wide = np.flatnonzero(h >= limit)
    if wide.size:
        raise ValueError(f"FE damage: an element {h.flat[wide[0]]:.4g} m wide is beyond the "
                         f"{sign} crack band's limit 2 {formula} = {limit:.4g} m (E {young:.4g} "
                         f"Pa, {name} {energy:.4g} J/m², strength {strength:.4g} Pa): it would "
                         f"snap back; refine the mesh or raise {name}")


def components(t):
    """The components (6, n) of symmetric tensors t (n, 3, 3)."""
    return np.stack([t[:, a, b] for a, b in PAIRS])


def tensors(v):
    """The symmetric tensors (n, 3, 3) of components v (6, n)."""
    out = np.empty((v.shape[1], 3, 3))
    for k, (a, b) in enumerate(PAIRS):
        out[:, a, b] = out[:, b, a] = v[k]
    return out


def trace(v):
    return v[0] + v[1] + v[2]


def contract(u, v):
    """u : v of components (6, n)."""
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2] + 2 * (u[3] * v[3] + u[4] * v[4]
                                                          + u[5] * v[5])


def positive_part(v):
    """The positive spectral parts Σ ⟨λ_i⟩ n_i⊗n_i of symmetric tensors v (6, n).

    With the eigenvalues λ₁ ≥ λ₂ ≥ λ₃ in closed form (the trigonometric solution of the
    characteristic cubic: Smith, CACM 4, 1961, 168): v itself where λ₃ ≥ 0,
    0 where λ₁ ≤ 0; with one positive, λ₁ P₁; with two, v − λ₃ P₃; the projector
    P_k = (v − λ_i 1)(v − λ_j 1) / ((λ_k − λ_i)(λ_k − λ_j)) (Sylvester). With mixed signs the
    denominators are at least |λ_k| and λ₁ − λ₃ ≥ max |λ|, so the error is that of the
    eigenvalues, machine ε |v|² / gap for a root of the characteristic cubic. Where two
    eigenvalues come within 10⁻³ |v| of each other (√ε |v| accurate only: a uniaxial
    stress) and the signs are not all one, Jacobi's method (backward stable:
    the projection on the positive tensors does not amplify its rounding)."""
    v = contiguous(v)
    out = np.empty_like(v)
    library().positive_part(v.shape[1], v, out)
    return out


def fit_compressive_fracture_energy(strain, stress, length, specimen_young, young, width):
    """Gc of the compression band that follows a specimen's measured post-peak branch.

    strain, stress: the specimen's curve (shortening between the loaded ends, compression
    negative, as the calibration's compression test records it); length: the specimen's (m);
    specimen_young: its modulus between the ends (its elastic unloading); young: the FE's E;
    width: the FE cells' h. Past the peak the specimen shortens, beyond its elastic L σ / E_s,
    by δ(σ) (taken from its value at the peak). In the FE, a band of width h softening and
    the rest unloading elastically, δ(σ) = h (fc − σ)/E + δ_c ln(fc / σ), δ_c = h k ε_fc: δ_c
    is the least-squares fit of the measured δ on the post-peak samples, and
    Gc = h (fc² / 2E + k fc ε_fc) = h fc² / 2E + fc δ_c.
    Returns (Gc, δ_c, the number of post-peak samples fitted)."""
    s, e = -np.asarray(stress, float), -np.asarray(strain, float)
    peak = int(np.argmax(s))
    fc = s[peak]
    post = slice(peak + 1, None)
    if s[post].size < 2 or not s[post].min() < 0.99 * fc:
        raise ValueError(f"compression curve: no post-peak branch to fit (peak at sample "
                         f"{peak} of {s.size})")
    excess = length * (e - s / specimen_young)
    sp, ex = s[post], excess[post] - excess[peak] - width * (fc - s[post]) / young
    log = np.log(fc / sp)
    delta = float(log @ ex / (log @ log))
    return width * fc * fc / (2 * young) + fc * delta, delta, int(sp.size)


def band_width(gradients, direction):
    """Oliver's element width 2 / Σ_i |∇N_i · n| for cells with shape-function gradients at
    their centres (n, nv, 3) and unit directions (n, 3)."""
    return 2.0 / np.abs(np.einsum("cia,ca->ci", gradients, direction)).sum(axis=1)
