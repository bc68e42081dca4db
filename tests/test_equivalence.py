"""The equivalence yardstick on cases whose answers are known: intervals by hand (the t quantile of
2 degrees of freedom in closed form, t_{p,2} = (2p - 1)/sqrt(2p(1 - p))), Welch's textbook
formula, verdicts on both sides of each boundary, and the simulated size and power against the
exact integrals within 4 binomial standard errors."""
import json

import numpy as np
import pytest
from scipy import stats

from orchestrator import equivalence as eq

T2 = 0.9 / np.sqrt(2 * 0.95 * 0.05)       # t_{0.95, 2}
E3 = np.array([-1.0, 0.0, 1.0])           # mean 0, sd 1
DRAWS = 4000
MEMBERS = (3, 4, 6)
SPREADS = (0.02, 0.05, 0.1, 0.15, 0.2, 0.3)   # the table's, margin 0.1


def paired(d, mean=1.0):
    """Full members at `mean`, coupled ones at mean·(1 + d): relative differences d."""
    full = {k: mean for k in range(len(d))}
    return full, {k: mean + abs(mean) * dk for k, dk in enumerate(d)}


def welch(f, c):
    return dict(enumerate(f)), {100 + k: v for k, v in enumerate(c)}


def standard(n):
    """n values of mean 0 and sd (ddof 1) 1."""
    e = np.arange(n) - (n - 1) / 2
    return e / e.std(ddof=1)


def se4(p):
    return 4 * np.sqrt(p * (1 - p) / DRAWS)


# --- the interval by hand -------------------------------------------------------------------

@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_paired_interval_by_hand(sign):
    # seeds 1-3 paired; full seed 5 counts in the mean only, coupled seed 7 nowhere
    full = {1: 9.0, 2: 10.0, 3: 11.0, 5: 12.0}
    m = sign * 10.5
    full = {s: sign * v for s, v in full.items()}
    coupled = {s: full[s] + 10.5 * d for s, d in zip((1, 2, 3), (0.01, 0.03, 0.02))}
    coupled[7] = 3.0
    r = eq.scalar(full, coupled, 0.1)
    half = T2 * 0.01 / np.sqrt(3)
    assert (r["test"], r["n_full"], r["n_coupled"], r["n_pairs"]) == ("paired", 4, 4, 3)
    assert r["full_mean"] == pytest.approx(m, abs=1e-12)
    assert r["difference"] == pytest.approx(0.02, abs=1e-12)
    assert r["interval"] == pytest.approx([0.02 - half, 0.02 + half], abs=1e-12)
    assert r["se"] == pytest.approx(0.01 / np.sqrt(3), abs=1e-12)
    assert r["dof"] == 2.0
    assert r["verdict"] == "equivalent"
    json.dumps(r)


def test_welch_interval_textbook():
    f = np.array([1.0, 1.1, 0.9])
    c = np.array([1.05, 0.95, 1.2, 1.0])
    r = eq.scalar(*welch(f, c), 0.1)
    m = f.mean()
    vf, vc = f.var(ddof=1) / 3 / m ** 2, c.var(ddof=1) / 4 / m ** 2
    nu = (vf + vc) ** 2 / (vf ** 2 / 2 + vc ** 2 / 3)
    d = (c.mean() - f.mean()) / m
    half = stats.t.ppf(0.95, nu) * np.sqrt(vf + vc)
    assert (r["test"], r["n_pairs"]) == ("welch", 0)
    assert r["dof"] == pytest.approx(nu, abs=1e-12)
    assert r["interval"] == pytest.approx([d - half, d + half], abs=1e-12)
    assert r["verdict"] == ("cannot judge" if np.sqrt(vf + vc) * (stats.t.ppf(0.95, nu) + eq.Z)
                            > 0.1 else "equivalent" if abs(d) + half <= 0.1
                            else "not equivalent")


def test_one_shared_seed_is_welch():
    r = eq.scalar({1: 1.0, 2: 1.1}, {1: 1.0, 3: 1.05}, 0.5)
    assert (r["test"], r["n_pairs"]) == ("welch", 0)


def test_no_difference_no_spread_is_equivalent():
    r = eq.scalar({1: 2.0, 2: 3.0}, {1: 2.0, 2: 3.0}, 0.01)
    assert (r["interval"], r["se"], r["verdict"]) == ([0.0, 0.0], 0.0, "equivalent")


def test_known_spread_passes_goal_at_the_limit():
    # at se·(t + z) = δ and zero bias, |d̄/se| ≤ z: probability 2Φ(z) - 1
    assert 2 * stats.norm.cdf(eq.Z) - 1 == pytest.approx(eq.GOAL, abs=1e-12)


# --- verdicts on both sides of each boundary --------------------------------------------------

@pytest.mark.parametrize("mu", [0.05, -0.05])
def test_paired_equivalence_boundary(mu):
    upper = abs(mu) + T2 * 0.01 / np.sqrt(3)          # |d̄| + t·se; the limit is 0.026
    full, coupled = paired(mu + 0.01 * E3)
    assert eq.scalar(full, coupled, upper * (1 + 1e-9))["verdict"] == "equivalent"
    assert eq.scalar(full, coupled, upper * (1 - 1e-9))["verdict"] == "not equivalent"


@pytest.mark.parametrize("mu, inside", [(0.0, "equivalent"), (0.05, "not equivalent")])
def test_paired_cannot_judge_boundary(mu, inside):
    limit = 0.03 / np.sqrt(3) * (T2 + eq.Z)           # 0.079; t·se = 0.051
    full, coupled = paired(mu + 0.03 * E3)
    assert eq.scalar(full, coupled, limit * (1 + 1e-9))["verdict"] == inside
    assert eq.scalar(full, coupled, limit * (1 - 1e-9))["verdict"] == "cannot judge"


@pytest.mark.parametrize("mu", [0.3, -0.3])
def test_an_interval_wholly_beyond_the_margin_is_not_equivalent_whatever_the_spread(mu):
    """d̄ = ±0.3, t·se = 0.051 (se 0.0173): the interval [0.249, 0.351] lies beyond any margin
    below |d̄| - t·se, though its spread is too wide for margins below se·(t + z) = 0.079."""
    full, coupled = paired(mu + 0.03 * E3)
    lower = abs(mu) - T2 * 0.03 / np.sqrt(3)
    assert eq.scalar(full, coupled, lower * (1 - 1e-9))["verdict"] == "not equivalent"
    assert eq.scalar(full, coupled, 0.05)["verdict"] == "not equivalent"
    assert eq.scalar(full, coupled, lower * (1 + 1e-9))["verdict"] == "not equivalent"  # U > δ
    assert eq.history(*paired_histories(2 * mu, 0.06), lower * (1 - 1e-9))["verdict"] == \
        "not equivalent"


def test_welch_boundaries():
    f, c = 1 + 0.01 * E3, 1.04 + 0.02 * standard(4)
    m = f.mean()
    vf, vc = 0.01 ** 2 / 3 / m ** 2, 0.02 ** 2 / 4 / m ** 2
    nu = (vf + vc) ** 2 / (vf ** 2 / 2 + vc ** 2 / 3)
    t, se = stats.t.ppf(0.95, nu), np.sqrt(vf + vc)
    upper, limit = abs(c.mean() - f.mean()) / m + t * se, se * (t + eq.Z)
    assert limit < upper
    members = welch(f, c)
    assert eq.scalar(*members, upper * (1 + 1e-9))["verdict"] == "equivalent"
    assert eq.scalar(*members, upper * (1 - 1e-9))["verdict"] == "not equivalent"
    assert eq.scalar(*members, limit * (1 + 1e-9))["verdict"] == "not equivalent"
    assert eq.scalar(*members, limit * (1 - 1e-9))["verdict"] == "cannot judge"


# --- histories --------------------------------------------------------------------------------

def paired_histories(mu, s):
    """Full members [0, 2, 2, 0] (P = 2), differences (mu + s·e_k)·[1, -1, 1, -1]: relative
    D = |mu|/2, se(t) = s/(2√3), U = (|mu| + t·s/√3)/2."""
    shape, sign = np.array([0.0, 2.0, 2.0, 0.0]), np.array([1.0, -1.0, 1.0, -1.0])
    full = {k: shape for k in range(3)}
    return full, {k: shape + (mu + s * e) * sign for k, e in enumerate(E3)}


def test_history_paired_by_hand():
    r = eq.history(*paired_histories(0.06, 0.02), 0.1)
    assert (r["test"], r["n_pairs"], r["peak"], r["dof"]) == ("paired", 3, 2.0, 2.0)
    assert r["difference"] == pytest.approx(0.03, abs=1e-12)
    assert r["upper"] == pytest.approx((0.06 + T2 * 0.02 / np.sqrt(3)) / 2, abs=1e-12)
    assert r["se"] == pytest.approx(0.02 / (2 * np.sqrt(3)), abs=1e-12)
    json.dumps(r)


def test_history_boundaries():
    members = paired_histories(0.06, 0.02)
    upper = (0.06 + T2 * 0.02 / np.sqrt(3)) / 2
    assert eq.history(*members, upper * (1 + 1e-9))["verdict"] == "equivalent"
    assert eq.history(*members, upper * (1 - 1e-9))["verdict"] == "not equivalent"
    members = paired_histories(0.0, 0.06)
    limit = 0.06 / (2 * np.sqrt(3)) * (T2 + eq.Z)
    assert eq.history(*members, limit * (1 + 1e-9))["verdict"] == "equivalent"
    assert eq.history(*members, limit * (1 - 1e-9))["verdict"] == "cannot judge"


def test_history_welch_textbook():
    rng = np.random.default_rng(3)
    base = eq.pulse()
    f = base * (1 + 0.05 * rng.standard_normal((3, 1))) + 0.01 * rng.standard_normal((3, 51))
    c = base * (1.03 + 0.08 * rng.standard_normal((5, 1))) + 0.02 * rng.standard_normal((5, 51))
    r = eq.history(*welch(f, c), 0.1)
    peak = np.abs(f.mean(axis=0)).max()
    d = (c.mean(axis=0) - f.mean(axis=0)) / peak
    vf, vc = f.var(axis=0, ddof=1) / 3 / peak ** 2, c.var(axis=0, ddof=1) / 5 / peak ** 2
    nu = (vf.mean() + vc.mean()) ** 2 / (vf.mean() ** 2 / 2 + vc.mean() ** 2 / 4)
    t = stats.t.ppf(0.95, nu)
    upper = np.sqrt(np.mean((np.abs(d) + t * np.sqrt(vf + vc)) ** 2))
    rms_se = np.sqrt(np.mean(vf + vc))
    assert (r["test"], r["peak"]) == ("welch", peak)
    assert r["dof"] == pytest.approx(nu, abs=1e-12)
    assert r["difference"] == pytest.approx(np.sqrt(np.mean(d ** 2)), abs=1e-12)
    assert r["upper"] == pytest.approx(upper, abs=1e-12)
    assert r["se"] == pytest.approx(rms_se, abs=1e-12)
    assert r["verdict"] == ("cannot judge" if rms_se * (t + eq.Z) > 0.1
                            else "equivalent" if upper <= 0.1 else "not equivalent")


# --- members needed ---------------------------------------------------------------------------

def needed(criterion):
    return next(n for n in range(2, 1001) if criterion(n))


def test_members_needed_paired():
    s, delta = 0.05, 0.1
    criterion = lambda n: s * (stats.t.ppf(0.95, n - 1) + eq.Z) / np.sqrt(n) <= delta
    n = needed(criterion)
    assert n > 3 and criterion(n) and not criterion(n - 1)
    r = eq.scalar(*paired(s * E3), delta)
    assert (r["verdict"], r["members_needed"]) == ("cannot judge", n)
    # with that many pairs of the same spread the ensemble can be judged, with one fewer not
    assert eq.scalar(*paired(s * standard(n)), delta)["verdict"] == "equivalent"
    assert eq.scalar(*paired(s * standard(n - 1)), delta)["verdict"] == "cannot judge"
    assert eq.scalar(*paired(s * standard(n)), delta)["members_needed"] == n


def test_members_needed_welch():
    sf, sc, delta = 0.03, 0.06, 0.1

    def criterion(n):
        nu = (n - 1) * (sf ** 2 + sc ** 2) ** 2 / (sf ** 4 + sc ** 4)
        return np.sqrt((sf ** 2 + sc ** 2) / n) * (stats.t.ppf(0.95, nu) + eq.Z) <= delta

    n = needed(criterion)
    assert n > 3 and criterion(n) and not criterion(n - 1)
    members = lambda k: welch(1 + sf * standard(k), 1 + sc * standard(k))
    r = eq.scalar(*members(3), delta)
    assert (r["verdict"], r["members_needed"]) == ("cannot judge", n)
    assert eq.scalar(*members(n), delta)["verdict"] == "equivalent"
    assert eq.scalar(*members(n - 1), delta)["verdict"] == "cannot judge"


def test_members_needed_beyond_the_search():
    assert eq.scalar(*paired(10.0 * E3), 0.01)["members_needed"] is None


# --- size and power ---------------------------------------------------------------------------

@pytest.mark.parametrize("n", MEMBERS)
def test_simulation_agrees_with_exact(n):
    for spread in (0.02, 0.035, 0.05, 0.1):
        r = eq.simulate("scalar", n, n, spread, 0.1, DRAWS, rng_seed=n)
        size, power = eq.exact_size(n, spread, 0.1), eq.exact_power(n, spread, 0.1)
        cannot = eq.exact_cannot_judge(n, spread, 0.1)
        assert abs(r["size"] - size) <= se4(size)
        assert abs(r["power"] - power) <= se4(power)
        assert abs(r["cannot_judge_size"] - cannot) <= se4(cannot)
        # same random numbers: at bias δ the lower bound moves some draws of a wide spread
        # from "cannot judge" to "not equivalent", none the other way
        assert r["cannot_judge_power"] <= r["cannot_judge_size"]


def test_exact_power_at_least_one_minus_alpha():
    for n in MEMBERS:
        for spread in SPREADS:
            assert eq.exact_power(n, spread, 0.1) >= 1 - eq.ALPHA - 1e-9


@pytest.mark.parametrize("kind, paired", [("scalar", True), ("scalar", False),
                                          ("history", True), ("history", False)])
def test_simulated_power(kind, paired):
    floor = 1 - eq.ALPHA - se4(1 - eq.ALPHA)
    for n in MEMBERS:
        for spread in SPREADS:
            r = eq.simulate(kind, n, n, spread, 0.1, DRAWS, rng_seed=n, paired=paired)
            assert r["power"] >= floor, (n, spread, r)


@pytest.mark.parametrize("n", MEMBERS)
def test_exact_size_monotone_and_bounded(n):
    spreads = np.linspace(0.005, 0.3, 13)
    size = np.array([eq.exact_size(n, s, 0.1) for s in spreads])
    assert np.all(np.diff(size) <= 1e-9)
    assert eq.exact_size(n, 1e-4, 0.1) >= 1 - 1e-9
    for s, p in zip(spreads[::3], size[::3]):
        assert p >= eq.size_lower_bound(n, s, 0.1) - 1e-9
    # the proven statement: size ≥ GOAL where σ(t + z)/√n ≤ δ·k_n
    k = eq.size_guaranteed_ratio(n)
    sigma = 0.1 * k * np.sqrt(n) / (stats.t.ppf(0.95, n - 1) + eq.Z)
    assert eq.size_lower_bound(n, sigma, 0.1) == pytest.approx(eq.GOAL, abs=1e-9)
    assert eq.exact_size(n, sigma, 0.1) >= eq.GOAL


def test_simulate_deterministic():
    a = eq.simulate("history", 3, 4, 0.05, 0.1, 300, rng_seed=7, paired=False)
    assert a == eq.simulate("history", 3, 4, 0.05, 0.1, 300, rng_seed=7, paired=False)
    assert a != eq.simulate("history", 3, 4, 0.05, 0.1, 300, rng_seed=8, paired=False)
    json.dumps(a)


def test_table():
    rows = eq.table(members=(3,), spreads=(0.02, 0.05), draws=200)
    assert [r["members"] for r in rows] == [3, 3]
    assert [r["spread_over_margin"] for r in rows] == pytest.approx([0.2, 0.5], abs=1e-12)
    assert rows[0]["size"] == eq.exact_size(3, 0.02, 0.1)
    text = eq.markdown(rows)
    assert "| 3 | 0.20 |" in text and "- 3 members: size ≥ 0.90 up to spread/margin 0.20" in text


# --- bad input --------------------------------------------------------------------------------

def one_line_error(call, *words):
    with pytest.raises(ValueError) as err:
        call()
    text = str(err.value)
    assert "\n" not in text and all(w in text for w in words), text


@pytest.mark.parametrize("margin", [0, -0.1, float("nan"), float("inf")])
def test_bad_margin(margin):
    one_line_error(lambda: eq.scalar(*paired(0.01 * E3), margin), "margin", repr(margin))
    one_line_error(lambda: eq.history(*paired_histories(0.0, 0.01), margin), "margin")
    one_line_error(lambda: eq.simulate("scalar", 3, 3, 0.05, margin, 10, 0), "margin")
    one_line_error(lambda: eq.exact_size(3, 0.05, margin), "margin")


def test_bad_members():
    one_line_error(lambda: eq.scalar({1: 1.0}, {2: 1.0, 3: 1.1}, 0.1), "1 full", "2 coupled")
    one_line_error(lambda: eq.scalar({1: 1.0, 2: 1.1}, {3: 1.0}, 0.1), "1 coupled")
    one_line_error(lambda: eq.simulate("scalar", 1, 3, 0.05, 0.1, 10, 0), "1 full")
    one_line_error(lambda: eq.scalar({1: 1.0, 2: float("nan")}, {1: 1.0, 2: 1.0}, 0.1),
                   "seed 2", "finite")


def test_bad_histories():
    full, coupled = paired_histories(0.0, 0.01)
    one_line_error(lambda: eq.history(full, {**coupled, 1: np.zeros(5)}, 0.1),
                   "coupled member of seed 1", "(5,)", "(4,)")
    one_line_error(lambda: eq.history({k: np.zeros(4) for k in range(3)}, coupled, 0.1),
                   "peak", "0")


def test_zero_full_mean():
    one_line_error(lambda: eq.scalar({1: -1.0, 2: 1.0}, {1: 0.0, 2: 0.1}, 0.1), "full mean",
                   "0.0")
