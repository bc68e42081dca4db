"""The yardstick: does a coupled model's ensemble (members = packing seeds) give the full model's
answer, for one scalar quantity of interest or one history? An equivalence test with a margin
stated before the runs (TOST, Schuirmann 1987).
Pure numpy and scipy.stats: imports nothing of the project.

Definitions
- ALPHA = 0.05: the verdict reads the 90 % (1 - 2α) confidence interval. GOAL = 0.90: the size
  and power the test is built for.
- MARGINS: δ relative to the full mean (of the full mean's |peak| for a peak, of its peak time,
  of its history's peak), stated before any run; a caller may give another, finite and > 0.
- Members are {seed: value}; a coupled and a full member with the same seed share the packing of
  the slab where both have spheres, and are a pair.

Scalar QoI (scalar). Differences are relative to the full members' mean m (all of them):
- paired, with at least 2 seeds in both: d_k = (c_k - f_k)/|m| over the n shared seeds;
  d̄ their mean, s their sd (ddof 1), se = s/√n, ν = n - 1;
- otherwise Welch, with at least 2 members of each model: d̄ = (mean c - mean f)/|m|,
  se² = s_c²/n_c + s_f²/n_f (relative), ν by Welch–Satterthwaite,
  ν = se⁴ / (s_c⁴/(n_c²(n_c - 1)) + s_f⁴/(n_f²(n_f - 1))); both sds zero: ν = n_c + n_f - 2,
  which only names the test (t·se = 0).
- Interval d̄ ± t·se, t = t_{1-α,ν}. TOST: each one-sided test rejects "|bias| ≥ δ" on its side
  at level α exactly when the interval's end on that side is inside, so "equivalent" when
  -δ ≤ d̄ - t·se and d̄ + t·se ≤ δ, i.e. U = |d̄| + t·se ≤ δ; else "not equivalent". All
  differences 0 with se = 0 is the interval [0, 0]: equivalent.
- "not equivalent" whatever the spread when the interval lies wholly beyond the margin,
  L = max(|d̄| - t·se, 0) > δ: the difference is shown larger than δ (each one-sided test at
  level α). This leaves the set judged "equivalent" as it is, so size and power too.
- "cannot judge", before the rest: se·(t + z) > δ, z = z_{1-α} = 1.645. Why that limit: if se were
  the known sd of d̄ and the bias zero, d̄/se ~ N(0, 1) and the ensemble passes when
  |d̄| ≤ δ - t·se. At se·(t + z) = δ that is |d̄/se| ≤ z, probability 2Φ(z) - 1 = 1 - 2α = GOAL
  exactly; at a smaller se, more. A spread past the limit would fail an unbiased coupled model
  more often than 1 - GOAL even if it were known: no verdict, never "equivalent".
- members_needed, always given: the smallest n ≤ MAX_MEMBERS (n pairs; Welch: n members of each
  model) at which the measured spread passes the limit, se(n)·(t_{1-α,ν(n)} + z) ≤ δ, with the
  same sds: paired se(n) = s/√n, ν = n - 1; Welch se(n)² = (s_c² + s_f²)/n,
  ν(n) = (n - 1)(s_c² + s_f²)²/(s_c⁴ + s_f⁴). None beyond MAX_MEMBERS. It is at most the members
  used exactly when the verdict is not "cannot judge" (paired; Welch with n_c = n_f).

History QoI (history): members are 1-D arrays on one common time base. P = max_t |f̄(t)|, the
full mean history's peak. Paired (≥ 2 shared seeds): d_k(t) = c_k(t) - f_k(t); else Welch at
each time as above. At each time d̄(t) and se(t); all relative to P. Statistic: the relative rms
of the mean difference, D = rms_t d̄(t); upper bound U = rms_t(|d̄(t)| + t·se(t)), lower bound
L = rms_t max(|d̄(t)| - t·se(t), 0) (L > δ: not equivalent, as for a scalar); the spread
rms_t se(t) = sqrt(Σ mean_t(s_i²(t))/n_i) over the components i (the paired differences; or the
coupled and the full members). ν: paired n - 1; Welch: Welch–Satterthwaite of the time-averaged
variances mean_t s_i²(t) (chosen over the smallest pointwise ν: it belongs to the rms'd spread
that the verdict reads, and it does not fall to min(n_c, n_f) - 1 by the chance of one time at
which one model's variance dominates; at one time it is the scalar's ν). Verdict: "cannot judge"
if rms_t se·(t + z) > δ, else "equivalent" if U ≤ δ, else "not equivalent"; members_needed as
for a scalar, with the time-averaged variances. A scalar is a history of one time: the two share
the code. U bounds the true relative rms difference Δ at level 1 - α exactly when the members'
deviations share one shape in time (d̄(t) - μ(t) = e·g(t): U < Δ needs e beyond the one-sided
t limit); deviations independent in time raise rms |d̄| (E d̄² = μ² + se²), which makes U
conservative. Between the two it is not proven: simulate measures it.

Size and power (simulate), from synthetic normal ensembles at the member counts used, in units
of the true full mean (1) or peak (1). Size: the fraction of draws judged "equivalent" when both
models share one distribution; power: the fraction NOT judged equivalent when the coupled model
is biased by δ (history: by δ·f(t)/rms_t f, a bias of relative rms δ). The same random numbers
serve both; the fraction "cannot judge" differs only by the draws whose interval the bias puts
wholly beyond the margin (not equivalent then).
- scalar paired: full members at exactly 1, coupled 1 + bias + spread·N(0, 1): `spread` is the
  sd of a pair difference, and m = 1 exactly: the model that exact_size integrates.
  Welch: each member 1 (+ bias) + spread·N(0, 1), m the drawn full mean.
- history: the pulse f(t) = sin(πt), t in [0, 1] at PULSE_SAMPLES times (peak 1 at t = 1/2, zero
  at both ends); member = f(t)·(1 + spread·ε_k) + NOISE·spread·η_k(t), ε_k, η_k(t) ~ N(0, 1)
  independent: a member's scale (and so its peak) scatters by `spread`, with white noise on
  top. Paired: full members are f(t) itself and the coupled ones carry the scatter; Welch: both.

Exact, paired scalar with differences N(bias, σ²) (exact_size, exact_power, exact_cannot_judge):
d̄ ~ N(bias, σ²/n) and s = σ·W, W² = χ²_ν/ν, independent. The verdict is "equivalent" when
s ≤ s* = δ√n/(t + z) and |d̄| ≤ a(s) = δ - t·s/√n (> 0 there), so
  P(equivalent) = ∫_0^{s*} f(s) [Φ((a(s) - bias)√n/σ) - Φ((-a(s) - bias)√n/σ)] ds,
integrated over u = F_χ²(ν s²/σ²) on [0, F_χ²(ν s*²/σ²)] (a bounded integrand on a bounded
range, whatever σ); size = P(equivalent | bias 0), power = 1 - P(equivalent | bias δ), with
(a - δ)√n/σ = -t·s/σ and (-a - δ)√n/σ = (-2δ + t·s/√n)√n/σ; P(cannot judge) = P(s > s*).
- Power ≥ 1 - α = 0.95 for every σ > 0: "equivalent" needs d̄ + t·se ≤ δ, and at bias δ
  (d̄ - δ)/se ~ t_ν, so P ≤ P(t_ν ≤ -t) = α.
- Size is non-increasing in σ and tends to 1 as σ → 0: with Z = d̄√n/σ and W fixed, the event
  {σ(|Z| + t·W) ≤ δ√n and σ·W(t + z) ≤ δ√n} shrinks as σ grows, and is every (Z, W) at σ → 0.
- Size ≥ F_χ²(ν/r²; ν)·(2Φ(z/r) - 1), r = σ(t + z)/(δ√n): W ≤ 1/r and |Z| ≤ z/r, independent,
  give both conditions. size_guaranteed_ratio(n) is the r at which this bound is GOAL: size ≥ GOAL
  wherever σ(t + z)/√n ≤ δ·size_guaranteed_ratio(n) (0.645 at n = 3: σ/δ ≤ 0.245; 0.675 at
  n = 4: 0.338; 0.714 at n = 6: 0.478). No such statement is proven for Welch or a history.
"""
import numpy as np
from scipy import integrate, optimize, stats

ALPHA = 0.05
GOAL = 0.90
MARGINS = {"peak": 0.10, "peak_time": 0.10, "history": 0.10}
Z = float(stats.norm.ppf((1 + GOAL) / 2))     # = z_{1-α}: 2Φ(z) - 1 = GOAL
MAX_MEMBERS = 1000
VERDICTS = ("equivalent", "not equivalent", "cannot judge")
PULSE_SAMPLES = 51                             # odd: t = 1/2, the pulse's peak, is sampled
NOISE = 0.5


def check_margin(margin):
    """δ as a float; a margin that is not finite and > 0 is a ValueError naming it."""
    delta = float(margin)
    if not (np.isfinite(delta) and delta > 0):
        raise ValueError(f"margin {margin!r}: needs a finite number > 0")
    return delta


def scalar(full, coupled, margin):
    """TOST of one scalar QoI. full, coupled: {seed: float}. See the module's docstring.
    Returns {"test", "n_full", "n_coupled", "n_pairs" (pairs used, 0 for Welch), "full_mean",
    "difference" (d̄), "interval" [lo, hi], "margin", "se", "dof", "members_needed",
    "verdict"}, relative figures, plain floats."""
    delta = check_margin(margin)
    full, coupled = _values(full, "full", None), _values(coupled, "coupled", None)
    test, f, c, f_all = _members(full, coupled)
    m = f_all.mean()
    if m == 0 or not np.isfinite(m):
        raise ValueError(f"full mean {float(m)!r}: needs a finite non-zero mean to be "
                         f"relative to")
    dbar, parts = _moments(f[:, None] / abs(m), c[:, None] / abs(m), test == "paired")
    se, rms_se, dof, t, upper, code = _judge(dbar, parts, delta)
    d, half = float(dbar[0]), float(t * se[0])
    return {"test": test, "n_full": len(full), "n_coupled": len(coupled),
            "n_pairs": len(f) if test == "paired" else 0, "full_mean": float(m),
            "difference": d, "interval": [d - half, d + half], "margin": delta,
            "se": float(rms_se), "dof": float(dof),
            "members_needed": _members_needed([(np.mean(s2), n) for s2, n in parts], delta),
            "verdict": VERDICTS[int(code)]}


def history(full, coupled, margin):
    """TOST of one history QoI. full, coupled: {seed: 1-D array}, one common time base.
    Returns {"test", "n_full", "n_coupled", "n_pairs", "peak" (P), "difference" (D),
    "upper" (U), "margin", "se" (rms_t se / P), "dof", "members_needed", "verdict"}."""
    delta = check_margin(margin)
    if not full:
        raise ValueError("members: 0 full; needs 2 shared seeds or 2 members of each model")
    length = len(np.ravel(next(iter(full.values()))))
    full, coupled = _values(full, "full", length), _values(coupled, "coupled", length)
    test, f, c, f_all = _members(full, coupled)
    peak = np.abs(f_all.mean(axis=0)).max()
    if peak == 0 or not np.isfinite(peak):
        raise ValueError(f"full mean history's peak {float(peak)!r}: needs a finite non-zero "
                         f"peak")
    dbar, parts = _moments(f / peak, c / peak, test == "paired")
    _, rms_se, dof, _, upper, code = _judge(dbar, parts, delta)
    return {"test": test, "n_full": len(full), "n_coupled": len(coupled),
            "n_pairs": len(f) if test == "paired" else 0, "peak": float(peak),
            "difference": float(_rms(dbar)), "upper": float(upper), "margin": delta,
            "se": float(rms_se), "dof": float(dof),
            "members_needed": _members_needed([(np.mean(s2), n) for s2, n in parts], delta),
            "verdict": VERDICTS[int(code)]}


def _members_needed(parts, margin):
    """Smallest n in 2..MAX_MEMBERS at which the spread of parts [(time-averaged relative
    variance s², members), ...] passes the judging limit with n in place of every member count;
    None beyond."""
    n = np.arange(2, MAX_MEMBERS + 1)
    rms_se, dof = _pooled([(s2, n) for s2, _ in parts])
    ok = rms_se * (stats.t.ppf(1 - ALPHA, dof) + Z) <= margin
    return int(n[ok.argmax()]) if ok.any() else None


def _values(members, kind, length):
    """{seed: float array of `length` times (None: a scalar)}; a value not finite, or of
    another shape, is a ValueError naming its seed."""
    out = {}
    for seed, value in members.items():
        v = np.asarray(value, float)
        if v.shape != (() if length is None else (length,)):
            need = "a scalar" if length is None else f"{(length,)} (one common time base)"
            raise ValueError(f"{kind} member of seed {seed}: shape {v.shape}, needs {need}")
        if not np.isfinite(v).all():
            raise ValueError(f"{kind} member of seed {seed}: {value!r}, needs finite values")
        out[seed] = v
    return out


def _members(full, coupled):
    """(test, f, c, all full members): the shared seeds' pairs in seed order when there are at
    least 2, else every member of each model (Welch, needing 2 of each)."""
    shared = sorted(set(full) & set(coupled))
    f_all = _stack(full, sorted(full))
    if len(shared) >= 2:
        return "paired", _stack(full, shared), _stack(coupled, shared), f_all
    if len(full) < 2 or len(coupled) < 2:
        raise ValueError(f"members: {len(full)} full, {len(coupled)} coupled, {len(shared)} "
                         f"shared seeds; needs 2 shared seeds or 2 members of each model")
    return "welch", f_all, _stack(coupled, sorted(coupled)), f_all


def _stack(members, seeds):
    return np.array([members[s] for s in seeds])


def _moments(f, c, paired):
    """Mean difference c - f (..., times) over the members' axis -2 of f, c (..., members,
    times), and its variance components [(s² (..., times), members)]: the pairs' differences,
    or the coupled and the full members."""
    if paired:
        d = c - f
        return d.mean(axis=-2), [(d.var(axis=-2, ddof=1), d.shape[-2])]
    return (c.mean(axis=-2) - f.mean(axis=-2),
            [(x.var(axis=-2, ddof=1), x.shape[-2]) for x in (c, f)])


def _pooled(parts):
    """rms se = sqrt(Σ s²/n) and ν of the variance components [(s², n)] (arrays broadcast):
    n - 1 for one component, else Welch–Satterthwaite (all variances zero: Σ(n - 1))."""
    if len(parts) == 1:
        (s2, n), = parts
        return np.sqrt(s2 / n), np.broadcast_to(n - 1.0, np.shape(s2 / n))
    u = [s2 / n for s2, n in parts]
    var = sum(u)
    den = sum(ui ** 2 / (n - 1) for ui, (_, n) in zip(u, parts))
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = np.where(den > 0, var ** 2 / den, sum(n - 1.0 for _, n in parts))
    return np.sqrt(var), dof


def _rms(x):
    return np.sqrt(np.mean(x ** 2, axis=-1))


def _judge(dbar, parts, delta):
    """TOST on the relative mean difference dbar (..., times) with variance components parts:
    (se (..., times), rms se, ν, t, U, verdict index into VERDICTS), each over the leading axes.
    At one time U = |d̄| + t·se exactly (sqrt(x²) = |x| in IEEE arithmetic, barring underflow),
    so a scalar's verdict is its interval's."""
    se = np.sqrt(sum(s2 / n for s2, n in parts))
    rms_se, dof = _pooled([(np.mean(s2, axis=-1), n) for s2, n in parts])
    t = stats.t.ppf(1 - ALPHA, dof)
    upper = _rms(np.abs(dbar) + np.expand_dims(t, -1) * se)
    lower = _rms(np.maximum(np.abs(dbar) - np.expand_dims(t, -1) * se, 0.0))
    code = np.where(lower > delta, 1, np.where(rms_se * (t + Z) > delta, 2,
                                               np.where(upper <= delta, 0, 1)))
    return se, rms_se, dof, t, upper, code


def pulse():
    """The synthetic histories' shape: sin(πt) at PULSE_SAMPLES times of [0, 1]."""
    return np.sin(np.pi * np.linspace(0.0, 1.0, PULSE_SAMPLES))


def simulate(kind, n_full, n_coupled, spread, margin, draws=4000, rng_seed=0, paired=True):
    """Size and power of the test of `kind` ("scalar" or "history") by `draws` synthetic
    ensembles (module docstring), deterministic for a rng_seed. Paired: the first
    min(n_full, n_coupled) seeds are pairs. Returns {"kind", "test", "n_full", "n_coupled",
    "spread", "margin", "draws", "size", "power", "cannot_judge_size", "cannot_judge_power"}."""
    delta = check_margin(margin)
    if kind not in ("scalar", "history"):
        raise ValueError(f"kind {kind!r}: needs 'scalar' or 'history'")
    spread = _check_spread(spread)
    if min(n_full, n_coupled) < 2:
        raise ValueError(f"members: {n_full} full, {n_coupled} coupled; needs 2 of each")
    shape = pulse() if kind == "history" else np.ones(1)
    rng = np.random.default_rng(rng_seed)
    coupled = _draw(rng, draws, n_coupled, spread, shape)
    full = np.broadcast_to(shape, coupled.shape[:1] + (n_full,) + shape.shape) if paired \
        else _draw(rng, draws, n_full, spread, shape)
    bias = delta * shape / _rms(shape)     # relative rms δ against the true peak (or mean) 1
    out = {"kind": kind, "test": "paired" if paired else "welch", "n_full": n_full,
           "n_coupled": n_coupled, "spread": spread, "margin": delta, "draws": draws}
    for name, offset in (("size", 0.0), ("power", bias)):
        code = _verdicts(kind, full, coupled + offset, paired, delta)
        out[name] = float(np.mean(code == 0) if name == "size" else np.mean(code != 0))
        out[f"cannot_judge_{name}"] = float(np.mean(code == 2))
    return out


def _draw(rng, draws, n, spread, shape):
    """(draws, n, times) members shape·(1 + spread·ε) (+ NOISE·spread·η for a history)."""
    scale = rng.standard_normal((draws, n, 1))
    members = shape * (1 + spread * scale)
    if shape.size > 1:
        members = members + NOISE * spread * rng.standard_normal((draws, n, shape.size))
    return members


def _verdicts(kind, full, coupled, paired, delta):
    """Verdict indices of synthetic ensembles full (draws, n_full, times) and coupled, one a
    draw, by the code that scalar and history use."""
    mean = full.mean(axis=1)
    norm = np.abs(mean[:, 0]) if kind == "scalar" else np.abs(mean).max(axis=1)
    norm = norm[:, None, None]
    if paired:
        pairs = min(full.shape[1], coupled.shape[1])
        full, coupled = full[:, :pairs], coupled[:, :pairs]
    dbar, parts = _moments(full / norm, coupled / norm, paired)
    return _judge(dbar, parts, delta)[-1]


def _check_spread(spread):
    if not (np.isfinite(spread) and spread > 0):
        raise ValueError(f"spread {spread!r}: needs a finite number > 0")
    return float(spread)


def _known(n, spread, margin):
    """(ν, σ, δ, t, √n, r) of the paired scalar test of n pairs, r = σ(t + z)/(δ√n)."""
    if n < 2:
        raise ValueError(f"n {n!r}: needs at least 2 pairs")
    nu, sigma, delta = n - 1, _check_spread(spread), check_margin(margin)
    t, root = stats.t.ppf(1 - ALPHA, nu), np.sqrt(n)
    return nu, sigma, delta, t, root, sigma * (t + Z) / (delta * root)


def _exact_equivalent(n, spread, margin, bias):
    """P(equivalent) of the paired scalar test: n pairs of differences N(bias, spread²)."""
    nu, sigma, delta, t, root, r = _known(n, spread, margin)
    top = stats.chi2.cdf(nu / r ** 2, nu)      # s ≤ s*: χ²_ν ≤ ν/r²

    def inside(u):
        s = sigma * np.sqrt(stats.chi2.ppf(u, nu) / nu)
        a = delta - t * s / root
        return (stats.norm.cdf((a - bias) * root / sigma)      # a ≥ δz/(t + z) > 0 here
                - stats.norm.cdf((-a - bias) * root / sigma))

    return integrate.quad(inside, 0.0, top, epsabs=1e-11, epsrel=1e-11, limit=200)[0]


def exact_size(n, spread, margin):
    """P(equivalent | bias 0) of the paired scalar test, n pairs, pair differences of sd
    `spread` (relative), by integration over the sample sd's distribution."""
    return _exact_equivalent(n, spread, margin, 0.0)


def exact_power(n, spread, margin):
    """P(not equivalent | bias = margin) of the paired scalar test, as exact_size."""
    return 1.0 - _exact_equivalent(n, spread, margin, check_margin(margin))


def exact_cannot_judge(n, spread, margin):
    """P(cannot judge) of the paired scalar test, whatever the bias: P(s > δ√n/(t + z))."""
    nu, *_, r = _known(n, spread, margin)
    return float(stats.chi2.sf(nu / r ** 2, nu))


def size_lower_bound(n, spread, margin):
    """The proven lower bound of exact_size: F_χ²(ν/r²; ν)·(2Φ(z/r) - 1), r = σ(t + z)/(δ√n)."""
    nu, *_, r = _known(n, spread, margin)
    return float(stats.chi2.cdf(nu / r ** 2, nu) * (2 * stats.norm.cdf(Z / r) - 1))


def size_guaranteed_ratio(n):
    """The r = σ(t + z)/(δ√n) at which size_lower_bound is GOAL: size ≥ GOAL at every r below."""
    scale = np.sqrt(n) / (stats.t.ppf(1 - ALPHA, n - 1) + Z)     # σ/δ per unit r
    return optimize.brentq(lambda r: size_lower_bound(n, r * scale, 1.0) - GOAL, 1e-3, 1.0,
                           xtol=1e-12)


def table(members=(3, 4, 6), spreads=(0.02, 0.05, 0.1, 0.15, 0.2, 0.3),
          margin=MARGINS["peak"], draws=2000, rng_seed=0):
    """Rows {members, spread_over_margin, size, power, cannot_judge} of the paired scalar test
    (exact), with history_size, history_power, history_cannot_judge of the paired history test
    (simulated, `draws` ensembles) beside them; spreads relative to the full mean."""
    rows = []
    for n in members:
        for spread in spreads:
            h = simulate("history", n, n, spread, margin, draws, rng_seed, paired=True)
            rows.append({"members": n, "spread_over_margin": spread / margin,
                         "size": exact_size(n, spread, margin),
                         "power": exact_power(n, spread, margin),
                         "cannot_judge": exact_cannot_judge(n, spread, margin),
                         "history_size": h["size"], "history_power": h["power"],
                         "history_cannot_judge": h["cannot_judge_size"]})
    return rows


def markdown(rows):
    """The table's rows as Markdown, then per member count the largest tabled spread/margin at
    which the exact size reaches GOAL, and the proven one (size_guaranteed_ratio)."""
    lines = ["| members | spread/margin | size | power | cannot judge | history size | "
             "history power | history cannot judge |", "|---:" * 8 + "|"]
    lines += [f"| {r['members']} | {r['spread_over_margin']:.2f} | {r['size']:.3f} | "
              f"{r['power']:.3f} | {r['cannot_judge']:.3f} | {r['history_size']:.3f} | "
              f"{r['history_power']:.3f} | {r['history_cannot_judge']:.3f} |" for r in rows]
    lines.append("")
    for n in sorted({r["members"] for r in rows}):
        ok = [r["spread_over_margin"] for r in rows if r["members"] == n and r["size"] >= GOAL]
        proven = size_guaranteed_ratio(n) * np.sqrt(n) / (stats.t.ppf(1 - ALPHA, n - 1) + Z)
        tabled = f"{max(ok):.2f}" if ok else "none"
        lines.append(f"- {n} members: size ≥ {GOAL:.2f} up to spread/margin {tabled} in the "
                     f"table; proven up to {proven:.3f}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown(table()))
