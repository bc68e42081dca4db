"""The criteria that judge a coupled model against the full one, in one place.

Absolute goals (the slab issue's): every sensor's peak within 10 % of the reference's, every
history's nRMS at most 15 %, the damaged volume within 15 %.

Relative verdict: is the coupled model's deviation from the full ensemble's mean no
larger than the full model's own scatter? The scatter of a member is its deviation from the mean
of the OTHER full members (leave-one-out): the mean of all members includes the member itself and
so understates its distance, by the factor (n-1)/n (orchestrator/ensemble.py: histories). For
members of spread σ, a coupled run with the full model's statistics lies at E[rms²] = σ²(1 + 1/n)
from the mean of n full runs, a full member at σ²(1 + 1/(n-1)) from the mean of the others; with
leave-in figures, σ²(1 - 1/n), a coupled run as good as the full model would be judged outside
the scatter (n = 2: 1.5 σ² against 0.5 σ²). The verdict compares the LARGEST coupled deviation
with the LARGEST leave-one-out deviation. It needs 2 full members; with 2 the two leave-one-out
deviations are one and the same figure (their difference), a single sample of the spread: such a
verdict is flagged weak (below WEAK_BELOW members).

A scatter can also be too wide to judge anything: each verdict says whether a null prediction
(a history that stays at zero, no damage) would be within it too (`null_within`). Its deviation
is exact: the peak's and a damage figure's |0 / mean - 1| = 1, the nRMS rms(mean) / peak(mean)
(orchestrator/ensemble.py: histories). Such a figure is no evidence either way: an impact whose
full members barely damage the slab (10 m/s at medium scale) has a damaged-volume scatter past 1.
"""
PEAK_RATIO_TOLERANCE = 0.10
HISTORY_NRMS_MAX = 0.15
DAMAGED_VOLUME_TOLERANCE = 0.15

MIN_FULL_MEMBERS = 2
WEAK_BELOW = 3


def absolute_goals(nrms, peak_ratio, damaged_volume_ratio):
    """The slab issue's goals for one coupled run against one reference. nrms, peak_ratio:
    {sensor: figure or None} (None: undefined, fails); damaged_volume_ratio: float or None."""
    return {
        "peaks_within_10_percent": all(r is not None and abs(r - 1) <= PEAK_RATIO_TOLERANCE
                                       for r in peak_ratio.values()),
        "history_nrms_at_most_15_percent": all(e is not None and e <= HISTORY_NRMS_MAX
                                               for e in nrms.values()),
        "damaged_volume_within_15_percent": damaged_volume_ratio is not None
                                            and abs(damaged_volume_ratio - 1)
                                            <= DAMAGED_VOLUME_TOLERANCE,
    }


def ensemble_goals(histories, damage):
    """absolute_goals of each coupled member against the full mean and against the full member of
    its seed. histories, damage: the results of orchestrator.ensemble.histories and .damage.
    Returns {"coupled_vs_full_mean": [goals], "paired": [goals]}, in the order of the
    histories' "coupled_seeds" and "paired_seeds"."""
    out = {}
    for kind, seeds in (("coupled_vs_full_mean", histories["coupled_seeds"]),
                        ("paired", histories["paired_seeds"])):
        sensors, volume = histories[kind], damage[kind]["damaged_volume_m3"]["ratio"]
        out[kind] = [absolute_goals({s: v["nrms"][i] for s, v in sensors.items()},
                                    {s: v["peak_ratio"][i] for s, v in sensors.items()},
                                    volume[i])
                     for i in range(len(seeds))]
    return out


def check_members(n_full, n_coupled):
    if n_full < MIN_FULL_MEMBERS:
        raise ValueError(f"a verdict against the full model's scatter needs at least "
                         f"{MIN_FULL_MEMBERS} full runs (seeds), got {n_full}")
    if n_coupled < 1:
        raise ValueError("a verdict against the full model's scatter needs a coupled run, got 0")


NULL_DEVIATION = 1.0      # a peak's or a damage figure's, of a null prediction: |0 / mean - 1|


def _verdict(coupled, full_loo, n_full, null=NULL_DEVIATION):
    """Largest coupled deviation against the largest leave-one-out full deviation (None: an
    undefined figure, which fails); `null`: a null prediction's deviation."""
    if any(d is None for d in coupled) or any(d is None for d in full_loo):
        return {"coupled_max": None, "full_leave_one_out_max": None, "within": False,
                "n_full": n_full, "weak": n_full < WEAK_BELOW, "null_within": None}
    c, f = max(coupled), max(full_loo)
    return {"coupled_max": c, "full_leave_one_out_max": f, "within": c <= f,
            "n_full": n_full, "weak": n_full < WEAK_BELOW,
            "null_within": None if null is None else null <= f}


def _deviations(ratios):
    return [None if r is None else abs(r - 1) for r in ratios]


def within_full_scatter(histories, damage=None):
    """Per sensor (nRMS, and the peak's relative deviation |ratio - 1|) and for the damage
    figures (|ratio - 1|): is the largest coupled deviation from the full mean no larger than the
    largest leave-one-out full deviation? See the module's docstring.
    histories, damage: the results of orchestrator.ensemble.histories and .damage.
    Returns {"sensors": {sensor: {"nrms": verdict, "peak": verdict}}, "damage":
    {"damaged_volume_m3": verdict, "broken_links": verdict} (without damage: absent)};
    verdict = {"coupled_max", "full_leave_one_out_max", "within", "n_full", "weak",
    "null_within"}."""
    n_full = len(histories["full_seeds"])
    check_members(n_full, len(histories["coupled_seeds"]))
    out = {"sensors": {}}
    for name, full in histories["full_scatter"].items():
        coupled = histories["coupled_vs_full_mean"][name]
        peak = _verdict(_deviations(coupled["peak_ratio"]),
                        _deviations(full["peak_ratio_leave_one_out"]), n_full)
        out["sensors"][name] = {
            "nrms": _verdict(coupled["nrms"], full["nrms_leave_one_out"], n_full,
                             full.get("null_nrms")), "peak": peak}
    if damage is not None:
        out["damage"] = damage_within_full_scatter(damage)
    return out


def damage_within_full_scatter(damage):
    """The damage figures' verdicts of within_full_scatter alone: {figure: verdict}."""
    n = len(damage["full_seeds"])
    check_members(n, len(damage["coupled_seeds"]))
    out = {}
    for key, full in damage["full"].items():
        coupled = damage["coupled_vs_full_mean"][key]
        if not any(full["members"]) and not any(coupled["members"]):
            # no member damaged: they agree exactly, and so would a null prediction
            out[key] = dict(_verdict([0.0], [0.0], n), null_within=True)
            continue
        out[key] = _verdict(_deviations(coupled["ratio"]),
                            _deviations(full["ratio_leave_one_out"]), n)
    return out
