"""The relaxation r (and the number of bridging layers n_b) that absorb the spurious
high-frequency (HF) wave at a DE/FE interface: derived from the coupled model itself.

Pure numpy, and it knows nothing of the rest of the project: its inputs are the
discretisation ratio (FE element length / sphere spacing), n_b, the solver variant, the time
step as a fraction of the critical step, and the weighting. docs/wave1d.md gives the
derivation and the measurements; in short:

1. Per step, the relaxed correction moves a bridging sphere by −(s/r) times its predicted
   gap to the FE, where s = D⁻¹ / S̄ is the sphere's share of the lumped multiplier matrix;
   with the bridging weights s = α (the FE's weight) to within the element's interpolation.
   On a motion that the FE cannot follow (the HF wave, above its cut-off 2c/h) the gap is
   the sphere's whole motion, and the corrected leap-frog x⁺ = (1 − ε)(2x − x⁻ + Δt²F/m)
   with ε = s/r has the roots z of z² − (1 − ε)(2 − Ω²) z + (1 − ε) = 0, |z|² = 1 − ε: the
   coupling removes a fraction ε of the wave's energy per step (a dashpot) and adds a
   spring of stiffness ε m / Δt² (the real part of ε z / (1 − ε), z = e^{iΩ}, Ω = ω Δt).
2. A packet crossing the ramp α = 0…1 of the band and back at the chain's group velocity
   v_g spends N = n_b h / (v_g Δt) steps per crossing (N = n_b × ratio × c / (v_g τ),
   τ = c Δt / L): the energy left is exp(−N / r) if it reaches the band's deep end, and
   99 % attenuation wants r ≤ N / ln 100.
3. It reaches the deep end only if the added spring stays below the packet's own stiffness,
   ε cos Ω < 4 sin²(Ω/2), i.e. r > r_t ≈ 1/Ω² (1/(ω_hf Δt)²): for smaller r it turns back
   where α = r Ω², having been damped only on the way there. The spring / dashpot ratio is
   cot Ω ≈ 1/Ω, so at small steps the relaxation is mostly a spring that reflects: the best
   r sits just above r_t (the packet slows down near its turning point at the deep end) and
   the absorbed fraction there falls with Δt, N / r_t ∝ n_b ω_hf² L Δt / v_g.
4. Too soft a coupling (large r) lets the low-frequency (LF) wave's own gap grow: the loss
   of transmitted LF energy grows with r (ω_LF Δt)².

These approximations say what sets r and n_b; the rule itself evaluates the exact harmonic
response of the discrete coupled model (point 1 without approximation: leap-frog on both
partners, the lumped or full multipliers, the bridging weights, with radiation conditions
on both sides), at the HF packet of the 1D study (ω_hf = √(2c/h × 2c/L), ±8 %) and the band
of its LF pulse (c T = 20 h), and takes the r with the most margin to the goal
(≥ 99 % of the HF energy removed, LF transmission changed by < 1 %). `auto_layers` adds
layers where no r reaches that goal with a margin of 1.2 on the prediction.
"""
import math

import numpy as np

# r given by a rule: "auto", the 1D band's (auto_relaxation); "rho", the lumping ratio ρ of the
# model's own multiplier matrix (orchestrator.coupling.correction.Coupling)
RELAXATION_RULES = ("auto", "rho")
GOAL_ATTENUATION = 0.99        # fraction of the reflected energy removed
GOAL_LF_CHANGE = 0.01          # |relative change of the transmitted LF energy|
WEIGHT_FLOOR = 0.01            # α, β ≥ this (the bridging weights' floor)
HF_BANDWIDTH = 0.08            # relative spectral std of the HF packet
LF_ELEMENTS = 20               # LF pulse sin²(π t / T) with c T = 20 h
REQUIRED_MARGIN = 1.2         # predicted reflected energy and |LF change| <= 1 % / 1.2
MAX_LAYERS = 24


class BandModel:
    """The harmonic (z = e^{iΩ}) response of the 1D coupled model across its bridging band:
    a chain of spheres (spacing L, mass M, links k, long-wave speed c) that fills the band
    and runs on to +∞, an FE bar of element h = ratio × L on the band that runs on to −∞,
    both advanced by leap-frog at the step τ L / c, and the bridging correction of the
    chosen solver and relaxation. Lengths in L, times in L / c, masses in M."""

    def __init__(self, ratio, layers, tau, weighting="consistent", variant="diagonal",
                 de_tail=2, fe_tail=1):
        if weighting not in ("nodal", "consistent"):
            raise ValueError(f"relaxation rule: weighting must be 'nodal' or 'consistent', "
                             f"got {weighting!r}")
        if variant not in ("full", "diagonal"):
            raise ValueError(f"relaxation rule: variant must be 'full' or 'diagonal', "
                             f"got {variant!r}")
        self.ratio, self.layers, self.tau = float(ratio), int(layers), float(tau)
        self.variant = variant
        q, nb = self.ratio, self.layers
        width = nb * q                                   # band width in L
        nc = int(math.floor(width + 1e-9)) + 1 + de_tail
        self.nc = nc
        x = np.arange(nc, dtype=float)                   # chain: x = 0 at the band's deep end
        beta = np.maximum(np.clip(x / width, 0, 1), WEIGHT_FLOOR)
        stations = np.arange(-fe_tail, nb + 1)           # FE stations at i h
        alpha = np.maximum(np.clip(1 - stations / nb, 0, 1), WEIGHT_FLOOR)
        consistent = weighting == "consistent"
        # chain (M = k = 1 in these units)
        m_c = beta if consistent else np.ones(nc)
        k_c = 0.5 * (beta[:-1] + beta[1:]) if consistent else np.ones(nc - 1)
        # FE bar: element stiffness EA/h = k / ratio, station mass ρAh = ratio M; consistent:
        # K = ∫ α EA N'N' (mean nodal α), m = ∫ α ρA N (α/3 + α_other/6 per element)
        a = alpha if consistent else np.ones_like(alpha)
        k_f = 0.5 * (a[:-1] + a[1:]) / q
        m_f = np.zeros(len(stations))
        m_f[:-1] += q * (a[:-1] / 3 + a[1:] / 6)
        m_f[1:] += q * (a[1:] / 3 + a[:-1] / 6)
        m_f[0] += q * (a[0] / 2)                         # the station left of it (α = 1)
        self.m = np.r_[m_c, m_f]
        n = len(self.m)
        K = np.zeros((n, n))
        for off, kk in ((0, k_c), (nc, k_f)):
            i = np.arange(len(kk)) + off
            K[i, i] += kk
            K[i + 1, i + 1] += kk
            K[i, i + 1] -= kk
            K[i + 1, i] -= kk
        K[nc, nc] += 1.0 / q                             # the bar runs on to the left
        K[nc - 1, nc - 1] += 1.0                         # the chain runs on to the right
        self.K = K
        # bridging spheres: 0 ≤ x ≤ width; interpolation N of the FE stations (hat functions)
        bridge = np.flatnonzero(x <= width + 1e-9)
        xs = x[bridge] / q                               # in elements from the deep end
        G = np.zeros((len(bridge), len(stations)))
        i0 = np.minimum(np.floor(xs).astype(int), nb - 1)
        t = xs - i0
        G[np.arange(len(bridge)), i0 + fe_tail] = 1 - t
        G[np.arange(len(bridge)), i0 + fe_tail + 1] = t
        B = np.zeros((len(bridge), n))
        B[np.arange(len(bridge)), bridge] = 1.0
        B[:, nc:] = -G
        de_w = np.ones(len(bridge)) if consistent else beta[bridge]
        fe_w = np.ones(len(stations)) if consistent else alpha
        cinv = np.zeros(n)                                # the coupling's inverse masses
        cinv[bridge] = 1.0 / (de_w * m_c[bridge])
        cinv[nc:] = 1.0 / (fe_w * m_f)
        S = (B * cinv) @ B.T
        Sinv = np.diag(1.0 / S.sum(axis=1)) if variant == "diagonal" else np.linalg.inv(S)
        self._corrector = (cinv[:, None] * B.T) @ Sinv @ B   # Δ = −corrector / r × predicted

    def response(self, omegas, relaxation):
        """(reflection, transmission) amplitudes, arrays over the angular frequencies `omegas`
        (in c/L), of a wave coming from the DE side: the reflected wave in the chain and the
        transmitted one in the bar, per unit incident displacement."""
        n, nc = len(self.m), self.nc
        Om = np.atleast_1d(np.asarray(omegas, float)) * self.tau
        z = np.exp(1j * Om)[:, None, None]
        s = np.sin(Om / 2) ** 2
        dt2 = self.tau ** 2
        mu_in, mu_out = _roots(2 - 4 * s / dt2)                        # chain: e^{+iθ}, e^{−iθ}
        nu_left = _roots(2 - 4 * s * self.ratio ** 2 / dt2)[1]          # bar, towards −x
        P = np.eye(n) - self._corrector / relaxation
        A = 2 * np.eye(n) - dt2 * self.K / self.m[:, None]
        H = z * np.eye(n) - (P @ A)[None] + P[None] / z
        # beyond the chain's last sphere: X_nc = μ_out X_{nc-1} + μ_in^{nc-1} (μ_in − μ_out);
        # beyond the bar's first station: u_{-1} = ν u_0 (outgoing, or decaying, towards −x)
        H[:, :, nc - 1] -= dt2 * mu_out[:, None] * P[None, :, nc - 1]
        H[:, :, nc] -= (dt2 / self.ratio / self.m[nc]) * nu_left[:, None] * P[None, :, nc]
        rhs = (dt2 * mu_in ** (nc - 1) * (mu_in - mu_out))[:, None] * P[None, :, nc - 1]
        X = np.linalg.solve(H, rhs[..., None])[..., 0]
        reflected = (X[:, nc - 1] - mu_in ** (nc - 1)) / mu_out ** (nc - 1)
        return reflected, X[:, nc]

    def flux(self, omegas, side):
        """Energy flux per unit squared amplitude of harmonic waves in the chain ("de") or the
        bar ("fe"), up to a factor common to both: k sin θ sin Ω (θ = κ × spacing; 0 above
        the cut-off)."""
        Om = np.asarray(omegas, float) * self.tau
        q2 = 1.0 if side == "de" else self.ratio ** 2
        c = 1 - 2 * np.sin(Om / 2) ** 2 * q2 / self.tau ** 2
        k = 1.0 if side == "de" else 1.0 / self.ratio
        return np.where(np.abs(c) < 1, k * np.sqrt(np.clip(1 - c * c, 0, None)) * np.sin(Om), 0.0)


def _roots(b):
    """The roots (1/μ, μ) of μ + 1/μ = b over an array of b: (e^{+iθ}, e^{−iθ}), θ in (0, π),
    where |b| < 2 (a propagating wave), else |μ| < 1 (the wave decaying towards −x)."""
    b = np.asarray(b, float)
    theta = np.arccos(np.clip(b / 2, -1, 1))
    real = b / 2 - np.sign(b) * np.sqrt(np.clip(b * b / 4 - 1, 0, None))
    mu = np.where(np.abs(b) < 2, np.exp(-1j * theta), real + 0j)
    return 1 / mu, mu


def study_spectra(ratio, lf_amplitude=1e-6, hf_amplitude=2e-7, points=24):
    """Angular frequencies (in c/L) and incident energy weights |Û(ω)|² of the 1D study's
    drive: the LF pulse sin²(π t / T), c T = 20 h, below the split c/h; the HF Gaussian packet
    at ω_hf = 2c / √(h L) with relative spectral std 8 %. Returns ((ω_lf, w_lf), (ω_hf, w_hf))
    (weights still to be multiplied by the flux factor)."""
    T = LF_ELEMENTS * ratio
    a = 2 * math.pi / T
    w_lf = np.linspace(1e-3, 1.0 / ratio, points) * (1 + 1e-7)   # off the 0/0 at ω = 2π/T
    u_lf = lf_amplitude * np.abs(np.sin(w_lf * T / 2)) * a * a / np.abs(w_lf * (w_lf ** 2 - a * a))
    w0 = 2.0 / math.sqrt(ratio)
    tau = 1.0 / (HF_BANDWIDTH * w0)
    w_hf = w0 * (1 + HF_BANDWIDTH * np.linspace(-3, 3, 13))
    u_hf = hf_amplitude * math.sqrt(2 * math.pi) * tau / 2 * np.exp(-0.5 * ((w_hf - w0) * tau) ** 2)
    return (w_lf, u_lf ** 2), (w_hf, u_hf ** 2)


def critical_tau(ratio, layers, weighting="consistent", tail=64):
    """c Δt_crit / L of the bridging band's chain: 2/ω_max of the chain that fills the band
    (masses and links weighted by β for the consistent weighting: its floor sphere is the
    stiffest part) and runs on for `tail` spheres; the bar's critical step, h/c, is larger."""
    width = layers * ratio
    x = np.arange(int(math.floor(width + 1e-9)) + 1 + tail, dtype=float)
    beta = np.maximum(np.clip(x / width, 0, 1), WEIGHT_FLOOR)
    m = beta if weighting == "consistent" else np.ones_like(x)
    k = 0.5 * (m[:-1] + m[1:])
    diag = (np.r_[k, 0.0] + np.r_[0.0, k]) / m
    off = -k / np.sqrt(m[:-1] * m[1:])
    lam = np.linalg.eigvalsh(np.diag(diag) + np.diag(off, 1) + np.diag(off, -1))[-1]
    return 2.0 / math.sqrt(lam)


class Prediction:
    """The band's predicted attenuation and LF transmission change as functions of r, for
    the 1D study's drive, against full Lagrange with r = 1 on the same band."""

    def __init__(self, ratio, layers, variant="diagonal", dt_safety=0.8,
                 weighting="consistent"):
        self.tau = dt_safety * critical_tau(ratio, layers, weighting)
        self.model = BandModel(ratio, layers, self.tau, weighting, variant)
        self.spectra = study_spectra(ratio)
        self._reference = self._energies(BandModel(ratio, layers, self.tau, weighting, "full"),
                                         1.0)

    def _energies(self, model, r):
        (wl, el), (wh, eh) = self.spectra
        R, _ = model.response(wh, r)
        Rl, Tl = model.response(wl, r)
        reflected = (np.sum(np.abs(R) ** 2 * model.flux(wh, "de") * eh)
                     + np.sum(np.abs(Rl) ** 2 * model.flux(wl, "de") * el))
        return reflected, np.sum(np.abs(Tl) ** 2 * model.flux(wl, "fe") * el)

    def __call__(self, relaxation):
        """(attenuation, LF transmission change), as fractions."""
        reflected, lf = self._energies(self.model, relaxation)
        return 1 - reflected / self._reference[0], lf / self._reference[1] - 1

    def best(self, per_decade=10, refine=12):
        """(r, attenuation, LF change) of the largest `margin` over r = 1 … 1000: a grid of
        `per_decade` points per decade, then a golden-section search around its best point."""
        grid = np.logspace(0, 3, 3 * per_decade + 1)
        scores = [margin(*self(r)) for r in grid]
        i = int(np.argmax(scores))
        lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, len(grid) - 1)])
        score = lambda v: margin(*self(math.exp(v)))
        g = (math.sqrt(5) - 1) / 2
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        fa, fb = score(a), score(b)
        for _ in range(refine):
            if fa > fb:
                hi, b, fb = b, a, fa
                a = hi - g * (hi - lo)
                fa = score(a)
            else:
                lo, a, fa = a, b, fb
                b = lo + g * (hi - lo)
                fb = score(b)
        candidates = [(scores[i], grid[i]), (fa, math.exp(a)), (fb, math.exp(b))]
        r = round(max(candidates)[1], 3)
        return (r, *self(r))


def margin(attenuation, lf_change):
    """How far inside the goal: min over the two criteria of goal / value (the reflected
    energy fraction against 1 %, |LF change| against 1 %); > 1 meets the goal."""
    reflected = max(1 - attenuation, 1e-12)
    return min((1 - GOAL_ATTENUATION) / reflected, GOAL_LF_CHANGE / max(abs(lf_change), 1e-12))


def auto_relaxation(ratio, layers, variant="diagonal", dt_safety=0.8, weighting="consistent"):
    """r for a band of `layers` layers: the r with the most margin to the goal (docs/wave1d.md).
    At a band too narrow for the goal it is still the best r there (see `auto_coupling`)."""
    ratio, dt_safety = _check(ratio, layers, dt_safety)
    return Prediction(ratio, layers, variant, dt_safety, weighting).best()[0]


def auto_layers(ratio, variant="diagonal", dt_safety=0.8, weighting="consistent", min_layers=3,
                max_layers=MAX_LAYERS, required=REQUIRED_MARGIN):
    """(n_b, (r, attenuation, LF change)) of the narrowest band from `min_layers` on whose
    best r meets the goal with `required` margin; n_b = None when none up to `max_layers`
    does (then the best found at max_layers)."""
    ratio, dt_safety = _check(ratio, min_layers, dt_safety)
    found = {}

    def ok(nb):
        found[nb] = Prediction(ratio, nb, variant, dt_safety, weighting).best()
        return margin(*found[nb][1:]) >= required

    if ok(min_layers):
        return min_layers, found[min_layers]
    # the margin grows with n_b: double, then bisect
    lo, hi = min_layers, min_layers
    while not ok(hi):
        lo = hi
        if hi == max_layers:
            return None, found[hi]
        hi = min(2 * hi, max_layers)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi, found[hi]


def layers_for(relaxation, ratio, variant="diagonal", dt_safety=0.8, weighting="consistent",
               min_layers=3, max_layers=MAX_LAYERS, required=REQUIRED_MARGIN):
    """(n_b, attenuation, LF change) of the narrowest band from `min_layers` on where the given
    r meets the goal with `required` margin; n_b = None when none up to `max_layers` does (the
    figures are then those of `min_layers`). At a fixed r the margin need not grow with n_b
    (r too small for a wide band's weights), so every width is tried in turn."""
    ratio, dt_safety = _check(ratio, min_layers, dt_safety)
    if not relaxation >= 1:
        raise ValueError(f"relaxation rule: r must be >= 1, got {relaxation!r}")
    first = None
    for nb in range(min_layers, max_layers + 1):
        figures = Prediction(ratio, nb, variant, dt_safety, weighting)(relaxation)
        first = first or figures
        if margin(*figures) >= required:
            return nb, *figures
    return None, *first


def auto_coupling(ratio, layers=3, variant="diagonal", dt_safety=0.8, weighting="consistent",
                  max_layers=MAX_LAYERS):
    """(r, n_b, reason): r alone at n_b = `layers` when it meets the goal there, else the
    narrowest wider band that does, else `layers` with its best r and the shortfall."""
    ratio, dt_safety = _check(ratio, layers, dt_safety)
    nb, (r, att, lf) = auto_layers(ratio, variant, dt_safety, weighting, layers, max_layers)
    figures = f"predicted attenuation {100 * att:.2f} %, LF change {100 * lf:+.2f} %"
    if nb == layers:
        return r, nb, f"r alone meets the goal at n_b = {layers}: {figures}"
    best = Prediction(ratio, layers, variant, dt_safety, weighting).best()
    short = (f"r alone reaches at most {100 * best[1]:.2f} % (LF {100 * best[2]:+.2f} %) "
             f"at n_b = {layers}")
    if nb is None:
        return best[0], layers, (f"goal out of reach up to n_b = {max_layers} ({figures}); "
                                 f"{short}, kept")
    return r, nb, f"n_b raised to {nb} ({figures}): {short}"


def _check(ratio, layers, dt_safety):
    if not ratio >= 1:
        raise ValueError(f"relaxation rule: ratio must be >= 1, got {ratio!r}")
    if int(layers) != layers or layers < 1:
        raise ValueError(f"relaxation rule: layers must be an integer >= 1, got {layers!r}")
    if not 0 < dt_safety <= 1:
        raise ValueError(f"relaxation rule: dt_safety must be in (0, 1], got {dt_safety!r}")
    # the same r for inputs that differ by round-off (a ratio computed from a mesh or a mean
    # radius): the search is not continuous in them at the last digit
    return round(float(ratio), 6), round(float(dt_safety), 6)
