"""Ensemble statistics: several packing realisations (seeds) of the full model against several of
the coupled model. Figures only; the criteria that judge them are in orchestrator/verdicts.py.

Definitions, as in the single-pair comparison of the slab (cases/slab.py compare()):
- a history is one displacement component per sensor, an array (n_times, n_sensors);
- peak(h) = max |h| over the compared window;
- nRMS(h, ref) = sqrt(mean((h - ref)²)) / peak(ref), on a common time base;
- peak ratio = peak(h) / peak(ref).
Members are given as {seed: ...}; a coupled and a full member with the same seed share the
packing of the slab where both have spheres. Per-member figures are lists in the order of the
sorted seeds, given beside them. Pure numpy: imports nothing of the project.
"""
import numpy as np


def check_same_kind(members):
    """Refuse members of different kinds. `members`: {label: {key: value}} of the keys that must
    agree (scale, steps, case, ...). The ValueError names the key and the two values."""
    (first, ref), *rest = members.items()
    for label, ids in rest:
        for key in sorted(set(ref) | set(ids)):
            if ref.get(key) != ids.get(key):
                raise ValueError(f"members differ in {key}: {ref.get(key)!r} ({first}) vs "
                                 f"{ids.get(key)!r} ({label})")


def common_time_base(runs):
    """The times of the first run inside the shortest common window (from the latest start to the
    earliest end) of all `runs`, an iterable of (t, h)."""
    runs = list(runs)
    start, end = max(t[0] for t, _ in runs), min(t[-1] for t, _ in runs)
    t = np.asarray(runs[0][0], float)
    t = t[(t >= start) & (t <= end)]
    if t.size < 2:
        raise ValueError(f"the runs share no time window: they span {start!r} to {end!r} s")
    return t


def resample(t, run):
    """History `run` = (t_run, h (n_times, n_sensors)) linearly interpolated at times `t`."""
    t_run, h = np.asarray(run[0], float), np.asarray(run[1], float)
    return np.column_stack([np.interp(t, t_run, h[:, i]) for i in range(h.shape[1])])


def peaks(h):
    """peak(h) per sensor: max |h| over time."""
    return np.abs(h).max(axis=0)


def nrms(h, ref):
    """nRMS(h, ref) per sensor (NaN where the reference has no peak)."""
    p = peaks(ref)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p > 0, np.sqrt(np.mean((h - ref) ** 2, axis=0)) / p, np.nan)


def ratio(a, b):
    """a / b, NaN where b has no positive value."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b > 0, a / b, np.nan)


def figures(x):
    """A list for JSON: NaN (undefined) as None."""
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(x, float).ravel()]


def leave_one_out_means(stack):
    """For each member i of `stack` (n, ...), the mean of the other members."""
    n = stack.shape[0]
    return (stack.sum(axis=0)[None] - stack) / (n - 1)


def histories(full, coupled, sensors):
    """Scatter of the full ensemble and deviation of the coupled members, per sensor.

    full, coupled: {seed: (t (n_times,), h (n_times, n_sensors))}; sensors: the n_sensors names.
    All histories are resampled onto common_time_base (full members first, in seed order).
    Returns {"time_window_s", "n_times", "full_seeds", "coupled_seeds", "paired_seeds",
    "full_scatter", "coupled_vs_full_mean", "paired"}, each of the last three {sensor: {...}}:
    - full_scatter: "mean_peak"; "peaks" and "peak_range" [min, max] of the members;
      "nrms" of each member against the ensemble mean; "nrms_leave_one_out" and
      "peak_ratio_leave_one_out" of each member against the mean of the others (None with one
      member). The leave-in figures include the member in its own reference and so understate
      the spread: for n independent members of spread σ, E[rms²(h_i - mean)] = σ²(1 - 1/n),
      E[rms²(h_i - mean of others)] = σ²(1 + 1/(n-1)); h_i - mean of others = n/(n-1)·(h_i - mean).
      "null_nrms": the nRMS of a history that stays at zero, rms(mean) / peak(mean): a scatter
      that large cannot tell a model from no answer at all.
    - coupled_vs_full_mean: "nrms" and "peak_ratio" of each coupled member against the mean.
    - paired: "nrms" and "peak_ratio" of each coupled member against the full member of its seed.
    """
    if not full:
        raise ValueError("an ensemble comparison needs at least one full run")
    for kind, runs in (("full", full), ("coupled", coupled)):
        for seed, (t, h) in runs.items():
            if np.ndim(h) != 2 or np.shape(h) != (len(t), len(sensors)):
                raise ValueError(f"{kind} run of seed {seed}: history of shape {np.shape(h)}, "
                                 f"expected ({len(t)}, {len(sensors)}) (times, sensors)")
    fs, cs = sorted(full), sorted(coupled)
    ps = [s for s in cs if s in full]
    t, hf, hc = _on_common_base(full, coupled)
    mean = hf.mean(axis=0)
    peak_m = peaks(mean)
    peak_f, peak_c = np.abs(hf).max(axis=1), np.abs(hc).max(axis=1)  # peaks: (members, sensors)
    dev_f = np.array([nrms(h, mean) for h in hf])
    if len(fs) > 1:
        others = leave_one_out_means(hf)
        dev_loo = np.array([nrms(h, m) for h, m in zip(hf, others)])
        peak_loo = ratio(peak_f, np.abs(others).max(axis=1))
    dev_c = np.array([nrms(h, mean) for h in hc]).reshape(len(cs), len(sensors))
    pair_c = [cs.index(s) for s in ps]
    pair_f = [fs.index(s) for s in ps]
    dev_p = np.array([nrms(hc[i], hf[j]) for i, j in zip(pair_c, pair_f)]).reshape(len(ps),
                                                                                    len(sensors))
    out = {"time_window_s": [float(t[0]), float(t[-1])], "n_times": int(t.size),
           "full_seeds": fs, "coupled_seeds": cs, "paired_seeds": ps,
           "full_scatter": {}, "coupled_vs_full_mean": {}, "paired": {}}
    for k, name in enumerate(sensors):
        out["full_scatter"][name] = {
            "mean_peak": float(peak_m[k]), "peaks": figures(peak_f[:, k]),
            "peak_range": [float(peak_f[:, k].min()), float(peak_f[:, k].max())],
            "nrms": figures(dev_f[:, k]),
            "nrms_leave_one_out": figures(dev_loo[:, k]) if len(fs) > 1 else None,
            "peak_ratio_leave_one_out": figures(peak_loo[:, k]) if len(fs) > 1 else None,
            "null_nrms": figures(nrms(np.zeros_like(mean[:, [k]]), mean[:, [k]]))[0]}
        out["coupled_vs_full_mean"][name] = {
            "nrms": figures(dev_c[:, k]), "peak_ratio": figures(ratio(peak_c[:, k], peak_m[k]))}
        out["paired"][name] = {
            "nrms": figures(dev_p[:, k]),
            "peak_ratio": figures(ratio(peak_c[pair_c, k], peak_f[pair_f, k]))}
    return out


def band(full, coupled):
    """(t, mean, min, max) of the full ensemble on the common time base of all runs (full and
    coupled, each {seed: (t, h)}), each (n_times, n_sensors): for plots."""
    t, hf, _ = _on_common_base(full, coupled)
    return t, hf.mean(axis=0), hf.min(axis=0), hf.max(axis=0)


def _on_common_base(full, coupled):
    """(t, full histories (n_full, n_times, n_sensors), coupled ones), members in seed order."""
    fs, cs = sorted(full), sorted(coupled)
    t = common_time_base([full[s] for s in fs] + [coupled[s] for s in cs])
    hf = np.stack([resample(t, full[s]) for s in fs])
    hc = np.stack([resample(t, coupled[s]) for s in cs]) if cs else np.zeros((0,) + hf.shape[1:])
    return t, hf, hc


DAMAGE_FIGURES = ("damaged_volume_m3", "broken_links")


def damage(full, coupled):
    """Damage figures of every member, their spread, and the coupled members against them.

    full, coupled: {seed: {"damaged_volume_m3": float, "broken_links": int}}.
    Returns {"full_seeds", "coupled_seeds", "paired_seeds", "full", "coupled_vs_full_mean",
    "paired"}, each of the last three {figure: {...}} for both figures:
    - full: "members", "mean", "range" [min, max], "ratio_leave_one_out" (each member over the
      mean of the others; None with one member);
    - coupled_vs_full_mean: "members" and "ratio" (over the full mean);
    - paired: "ratio" of each coupled member over the full member of its seed.
    """
    if not full:
        raise ValueError("an ensemble comparison needs at least one full run")
    fs, cs = sorted(full), sorted(coupled)
    ps = [s for s in cs if s in full]
    out = {"full_seeds": fs, "coupled_seeds": cs, "paired_seeds": ps,
           "full": {}, "coupled_vs_full_mean": {}, "paired": {}}
    for key in DAMAGE_FIGURES:
        try:
            f = np.array([float(full[s][key]) for s in fs])
            c = np.array([float(coupled[s][key]) for s in cs])
        except KeyError as err:
            raise ValueError(f"a member's damage lacks {err.args[0]!r}") from None
        out["full"][key] = {
            "members": figures(f), "mean": float(f.mean()), "range": [float(f.min()),
                                                                        float(f.max())],
            "ratio_leave_one_out": figures(ratio(f, leave_one_out_means(f)))
            if len(fs) > 1 else None}
        out["coupled_vs_full_mean"][key] = {"members": figures(c),
                                            "ratio": figures(ratio(c, f.mean()))}
        out["paired"][key] = {"ratio": figures(ratio(c[[cs.index(s) for s in ps]],
                                                       f[[fs.index(s) for s in ps]]))}
    return out


def correlation(a, b):
    """Pearson correlation, None where undefined (fewer than 2 values or a constant one)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.size < 2 or a.std() == 0 or b.std() == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def paired_map_correlation(full_index, full_damage, coupled_index, coupled_damage, mask=None):
    """Correlation of a same-seed pair's damage, sphere by sphere. The coupled spheres are a
    subset of the full ones: `*_index` are their indices in the full packing (slab_index);
    `mask` (coupled spheres) restricts the comparison, e.g. to the DE zone."""
    full_index, coupled_index = np.asarray(full_index), np.asarray(coupled_index)
    order = np.argsort(full_index)
    pos = np.searchsorted(full_index, coupled_index, sorter=order)
    pos = np.minimum(pos, full_index.size - 1)
    found = full_index[order[pos]] == coupled_index
    if not found.all():
        raise ValueError(f"{np.count_nonzero(~found)} coupled spheres (e.g. index "
                         f"{int(coupled_index[~found][0])}) are not in the full packing: "
                         f"not the same seed")
    d_full = np.asarray(full_damage, float)[order[pos]]
    d_coupled = np.asarray(coupled_damage, float)
    if mask is not None:
        d_full, d_coupled = d_full[mask], d_coupled[mask]
    return correlation(d_full, d_coupled)


def plan_grid(positions, values, weights, lo, hi, cell):
    """Plan view (x, y) of `values` on a grid of square cells of side `cell` over [lo, hi]
    (2 corners, x and y): the `weights`-weighted mean per cell, NaN in empty cells.
    Returns (grid (n_x, n_y), x centres, y centres)."""
    flat, n, centres = _plan_cells(positions, lo, hi, cell)
    w = np.asarray(weights, float)
    num = np.bincount(flat, w * np.asarray(values, float), n.prod())
    den = np.bincount(flat, w, n.prod())
    with np.errstate(invalid="ignore", divide="ignore"):
        grid = np.where(den > 0, num / np.where(den > 0, den, 1), np.nan).reshape(n)
    return grid, centres[0], centres[1]


def plan_sum(positions, values, lo, hi, cell):
    """plan_grid's grid, of the sum of `values` per cell (0 in empty cells)."""
    flat, n, centres = _plan_cells(positions, lo, hi, cell)
    return (np.bincount(flat, np.asarray(values, float), n.prod()).reshape(n), centres[0],
            centres[1])


def _plan_cells(positions, lo, hi, cell):
    """(the flat cell index of each position, cells along x and y, cell centres)."""
    lo, hi = np.asarray(lo, float)[:2], np.asarray(hi, float)[:2]
    if not cell > 0 or np.any(hi <= lo):
        raise ValueError(f"map grid: cell {cell!r} over {lo.tolist()}–{hi.tolist()}")
    n = np.maximum(np.ceil((hi - lo) / cell - 1e-9).astype(int), 1)
    ij = np.clip(((np.asarray(positions, float)[:, :2] - lo) // cell).astype(int), 0, n - 1)
    centres = [lo[a] + cell * (np.arange(n[a]) + 0.5) for a in (0, 1)]
    return ij[:, 0] * n[1] + ij[:, 1], n, centres


def mean_damage_maps(full, coupled, lo, hi, cell):
    """Mean damage maps of both ensembles and their correlation. Members of different seeds have
    different spheres, so each member's damage is first put on a common plan-view grid
    (volume-weighted mean per cell, plan_grid), then the grids are averaged over the members;
    a cell counts only where every member of the ensemble has spheres.

    full, coupled: {seed: (positions (n, 3), damage (n,), volume (n,))}: pass for the coupled
    members the spheres to compare (e.g. those of the DE zone).
    Returns {"x", "y" (cell centres), "full", "coupled" (grids (n_x, n_y), NaN: no data),
    "correlation" (over the cells that both maps hold; None if undefined)}.
    """
    def mean_grid(members):
        grids = [plan_grid(p, d, v, lo, hi, cell) for p, d, v in
                 (members[s] for s in sorted(members))]
        return np.mean([g for g, _, _ in grids], axis=0), grids[0][1], grids[0][2]
    if not full or not coupled:
        raise ValueError("mean damage maps need at least one full and one coupled run")
    g_full, x, y = mean_grid(full)
    g_coupled, _, _ = mean_grid(coupled)
    both = np.isfinite(g_full) & np.isfinite(g_coupled)
    return {"x": x, "y": y, "full": g_full, "coupled": g_coupled,
            "correlation": correlation(g_full[both], g_coupled[both])}
