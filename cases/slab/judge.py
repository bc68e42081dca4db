"""The yardstick: coupled slab runs judged against full ones on the quantities of interest
(cases.slab.quantities) by an equivalence test whose margins are stated before the runs
(orchestrator.equivalence). For each judged QoI:
- peak: its extreme over the compared window in the QoI's sense (quantities.peak_index: the
  largest descent of the impactor and of the slab, the largest contact force and
  penetration, the largest magnitude of the reaction), each member's, as a magnitude;
- peak_time: the time of that peak;
- history: the whole window, on the common time base of every member.
Each is "equivalent", "not equivalent" or "cannot judge" (the members' spread too wide for the
margin: with how many members it could). A QoI whose extreme is the window's last sample in
any member is "not judged": the window cut the response before its peak, and nothing about
the event can be read from it. The same-seed members share the DE zone's packing: the test
pairs them where two pairs or more exist."""
import numpy as np

from cases.slab.quantities import event_ends, peak_index
from orchestrator import ensemble, equivalence

# the QoIs judged and their statistics (the impactor's velocity peaks at its first sample,
# the impact speed: its history alone is judged); the rest of the profile is recorded and
# plotted, not judged (one verdict per place the engineer reads: the centre, and either side)
JUDGED = {
    "impactor_z": ("peak", "peak_time", "history"),
    "impactor_vz": ("history",),
    "contact_force": ("peak", "peak_time", "history"),
    "penetration": ("peak", "peak_time", "history"),
    "reaction": ("peak", "peak_time", "history"),
    "deflection_x1.25": ("peak", "peak_time", "history"),
    "deflection_x0.75": ("peak", "peak_time", "history"),
    "deflection_x1.75": ("peak", "peak_time", "history"),
}
STATISTICS = ("peak", "peak_time", "history")
NOT_JUDGED = "not judged"


def margins(value=None):
    """The margins of the three statistics: equivalence.MARGINS, or `value` for all (checked:
    finite and > 0)."""
    if value is None:
        return dict(equivalence.MARGINS)
    equivalence.check_margin(value)
    return {s: float(value) for s in STATISTICS}


def check_members(n_full, n_coupled, n_pairs):
    """The test needs two same-seed pairs, or two members of each model."""
    if n_pairs < 2 and (n_full < 2 or n_coupled < 2):
        raise ValueError(f"the equivalence test needs 2 same-seed pairs or 2 members of each "
                         f"model: got {n_full} full, {n_coupled} coupled, {n_pairs} pairs")


def judge(full, coupled, margin=None, totals=None):
    """Judge the QoIs of the members `full`, `coupled` ({seed: (t, names, values (n_times,
    n_qoi))}) with the margins of `margins(margin)`, and `totals` ({name: ({seed: full
    value}, {seed: coupled value})}: figures of the whole run, judged as a peak is, under the
    statistic "total"). Returns {"margins", "window_s", "members": {"full", "coupled",
    "pairs"}, "qoi": {name: {statistic: result}}} with the results of equivalence.scalar /
    .history, or {"verdict": "not judged", "last_sample": [labels]} for each statistic of a
    QoI cut by the window."""
    m = margins(margin)
    pairs = sorted(full.keys() & coupled.keys())
    check_members(len(full), len(coupled), len(pairs))
    t = ensemble.common_time_base((t, v) for t, _, v in [*full.values(), *coupled.values()])
    out = {"margins": m, "window_s": [float(t[0]), float(t[-1])],
           "members": {"full": sorted(full), "coupled": sorted(coupled), "pairs": pairs},
           "event_end_s": {side: {s: event_ends(*_within(t, run)) for s, run in members.items()}
                           for side, members in (("full", full), ("coupled", coupled))},
           "qoi": {}}
    for name, statistics in JUDGED.items():
        h = {side: {s: _column(t, run, name) for s, run in members.items()}
             for side, members in (("full", full), ("coupled", coupled))}
        k = {side: {s: peak_index(name, x) for s, x in h[side].items()} for side in h}
        cut = [f"{side} {s}" for side in h for s, i in sorted(k[side].items())
               if i == len(t) - 1]
        if cut:
            out["qoi"][name] = {s: {"verdict": NOT_JUDGED, "last_sample": cut}
                                for s in statistics}
            continue
        figures = {"peak": lambda side: {s: float(abs(x[k[side][s]]))
                                         for s, x in h[side].items()},
                   "peak_time": lambda side: {s: float(t[k[side][s]]) for s in h[side]}}
        out["qoi"][name] = {
            s: (equivalence.history(h["full"], h["coupled"], m[s]) if s == "history" else
                equivalence.scalar(figures[s]("full"), figures[s]("coupled"), m[s]))
            for s in statistics}
        if "peak" in statistics:
            out["qoi"][name]["peak"]["pair_bias"] = _pair_bias(
                figures["peak"]("full"), figures["peak"]("coupled"))
    for name, (f, c) in (totals or {}).items():
        out["qoi"][name] = {"total": equivalence.scalar(f, c, m["peak"])}
    return out


def _pair_bias(full, coupled):
    """{seed: coupled / full − 1} of the same-seed pairs' peaks."""
    return {str(s): coupled[s] / full[s] - 1 for s in sorted(full.keys() & coupled.keys())}


def bias_line(judgement):
    """The same-seed bias of every judged peak in one line: the pairs' mean and their range,
    or None without pairs."""
    parts = []
    for name, stats in judgement["qoi"].items():
        pairs = stats.get("peak", {}).get("pair_bias")
        if pairs:
            v = list(pairs.values())
            parts.append(f"{name} {100 * np.mean(v):+.1f} % [{100 * min(v):+.1f}, "
                         f"{100 * max(v):+.1f}]")
    return ("same-seed bias of the peaks (coupled / full − 1: mean [pairs' range]): "
            + "; ".join(parts)) if parts else None


def _within(t, run):
    """(times, values) of `run` (t, names, values) inside the compared window `t`."""
    times, _, values = run
    keep = times <= t[-1] * (1 + 1e-12)
    return times[keep], values[keep]


def window_warning(judgement):
    """One line if the window ends before the event in a full member (quantities.event_ends:
    the impactor stopped, rebounded or through, then the slab's centre risen back), else
    None."""
    ends = judgement["event_end_s"]["full"]
    short = {part: [str(s) for s, e in ends.items() if e[f"{part}_s"] is None]
             for part in ("impactor", "slab")}
    if not short["slab"]:
        return None
    what = (f"the impactor has not stopped, rebounded or gone through in full seeds "
            f"{', '.join(short['impactor'])}" if short["impactor"] else
            "the impactor has stopped, rebounded or gone through in every full member")
    return (f"the window ({1e3 * judgement['window_s'][1]:.3g} ms) ends before the impact does: "
            f"{what}; the slab's centre has not risen back by half its depth since then in "
            f"full seeds {', '.join(short['slab'])} (run more --steps; a slab broken under the "
            f"impact never rises)")


def _column(t, run, name):
    """The QoI `name` of `run` (t, names, values) at the times `t`, its unmeasured samples
    (NaN: cases.slab.quantities) left out of the interpolation."""
    times, names, values = run
    x = values[:, names.index(name)]
    ok = np.isfinite(x)
    return np.interp(t, times[ok], x[ok])


def failures(judgement):
    """{"not equivalent": [...], "cannot judge": [...], "not judged": [...]} of
    "QoI statistic" labels, and the number of statistics judged equivalent."""
    out = {"not equivalent": [], "cannot judge": [], NOT_JUDGED: []}
    equivalent = 0
    for name, stats in judgement["qoi"].items():
        for s, r in stats.items():
            if r["verdict"] == "equivalent":
                equivalent += 1
            else:
                out[r["verdict"]].append(f"{name} {s}")
    return out, equivalent


def named(kind, labels):
    """The labels a headline names: a QoI cut by the window once, not once per statistic."""
    if kind != NOT_JUDGED:
        return labels
    return list(dict.fromkeys(label.rsplit(" ", 1)[0] for label in labels))


def headline(judgement):
    """The judgement in one line, naming every statistic that is not equivalent."""
    fails, equivalent = failures(judgement)
    total = equivalent + sum(len(v) for v in fails.values())
    fails = {kind: named(kind, labels) for kind, labels in fails.items()}
    m = judgement["margins"]
    parts = [f"equivalent on {equivalent} of {total} (margins: peak {m['peak']:.0%}, time "
             f"{m['peak_time']:.0%}, history {m['history']:.0%} of the full mean)"]
    for kind, labels in fails.items():
        if labels:
            parts.append(f"{'NOT equivalent' if kind == 'not equivalent' else kind}: "
                         f"{', '.join(described(judgement, x) for x in labels)}")
    return "yardstick: " + "; ".join(parts)


def described(judgement, label):
    """A failing statistic with what it measured: the difference and its interval, or the
    members it needs, or the members whose extreme is the window's end."""
    if label in judgement["qoi"]:
        return f"{label} (extreme at the window's end)"
    name, s = label.rsplit(" ", 1)
    r = judgement["qoi"][name][s]
    if r["verdict"] == "cannot judge":
        need = r.get("members_needed")
        return f"{label} (needs {'more than 1000' if need is None else need} members)"
    if s == "history":
        return f"{label} ({r['difference']:.1%}, ≤ {r['upper']:.1%})"
    lo, hi = r["interval"]
    return f"{label} ({r['difference']:+.1%} [{lo:+.1%}, {hi:+.1%}])"
