"""The table of the study "where coupling pays", from its run folders: per configuration of each
impact, each sensor's deviation against the full ensemble's scatter (orchestrator.ensemble,
orchestrator.verdicts), the damaged volume against the full members', the per-step speed-up and
the sphere ratio, the total cost (an automatic zone's failed attempts included), and the goal:
within the full scatter on every sensor and the damaged volume, and at least GOAL_SPEEDUP
cheaper per step.

A coupled member is compared at its own sensors: the full members record them too
(cases.slab.probes), under the plain names when the zone and band are the full model's own
(the scale's), else as "LAYOUT/SENSOR" (layout_label)."""
import numpy as np

from cases.slab.compare import Run
from cases.slab.probes import full_names
from cases.slab.study.plan import Config, where
from orchestrator import ensemble, verdicts

GOAL_SPEEDUP = {"small": 5.0, "medium": 5.0, "paper": 10.0}   # per step, the issue's
SPEEDUP_SOURCES = {
    "timing": "timed back to back on CPU time, one window of each model in its own process "
              "(bench.worker; timing.json)",
    "runs": "the runs' own wall time per step (separate runs: unreliable on a loaded machine, "
            "0.46-2.57 measured for the same pair of models)",
}


def layout_label(run):
    """The label of the full members' probes for the planned coupled `run`'s sensors (None:
    the full model's own sensors)."""
    c = run.config
    if c.same_layout_as_full():
        return None
    return f"{c.layout}-seed-{run.seed}" if c.zone == "auto" else c.layout


def groups(runs):
    """{group: {"full": [planned], config: [planned]}} in plan order."""
    out = {}
    for r in runs:
        out.setdefault(r.config.group, {}).setdefault(r.config, []).append(r)
    return out


def build(runs, out, index=None, timing=None):
    """The table: {"impacts": [{"group", "scale", "velocity", "full": {...}, "configs":
    [...]}]} of the planned `runs` found in `out` (or among the reused ensembles `index`);
    `timing`: the one-window timing ({run folder: bench figures}), else the runs' own."""
    index = index or {}
    impacts = []
    for group, configs in groups(runs).items():
        full_cfg = next((c for c in configs if c.model == "full"), None)
        found = {c: {r.seed: (r, *where(r, out, index)) for r in rs} for c, rs in configs.items()}
        full = {}
        if full_cfg is not None:
            full = {seed: Run(f) for seed, (r, f, s) in found[full_cfg].items() if s is not None}
        first = next(iter(configs))
        impact = {"group": group, "scale": first.scale, "velocity": first.velocity,
                  "reinforced": first.reinforced,
                  "full": _full_figures(full_cfg, found.get(full_cfg, {}), full),
                  "configs": []}
        for c, members in found.items():
            if c.model != "full":
                impact["configs"].append(config_row(c, members, full, full_cfg, found, timing))
        impacts.append(impact)
    return {"impacts": impacts}


def _full_figures(cfg, members, full):
    if cfg is None:
        return {"seeds": [], "missing": []}
    summaries = {seed: s for seed, (_, _, s) in members.items() if s is not None}
    return {"seeds": sorted(full), "missing": sorted(set(members) - set(full)),
            "folders": {seed: str(f) for seed, (_, f, s) in members.items() if s is not None},
            "spheres": _mean([s["n_spheres"] for s in summaries.values()]),
            "steps": _first(summaries, "steps"), "dt": _first(summaries, "dt"),
            "wall_s": [spent(summaries[k]) for k in sorted(summaries)],
            "s_per_step": [summaries[k]["s_per_step"] for k in sorted(summaries)]}


def config_row(c, members, full, full_cfg, found, timing):
    """The figures of one coupled configuration (members: {seed: (planned, folder, summary)})."""
    done = {seed: (r, f, s) for seed, (r, f, s) in members.items() if s is not None}
    d = c.defaults()
    row = {"config": c.name, "model": "coupled", "zone": c.zone, "layers": d.layers,
           "fe_material": c.fe_material,
           "de_zone_m": None if c.zone == "auto" else d.de_zone,
           "full_width": None if c.zone == "auto" else d.full_width,
           "band_ratio": c.band_ratio,
           "seeds": sorted(done), "missing": sorted(set(members) - set(done)),
           "folders": {seed: str(f) for seed, (_, f, _) in done.items()}}
    row["cost"] = _cost(done, found.get(full_cfg, {}))
    limit = {seed for seed, (_, _, s) in done.items() if s.get("zone_outcome") == "limit"}
    runs = {seed: Run(f) for seed, (_, f, s) in done.items() if seed not in limit}
    row["zone_limit_seeds"] = sorted(limit)
    if limit:
        row["zone_message"] = done[min(limit)][2].get("zone_message")
    if runs:
        s = [done[k][2] for k in sorted(runs)]
        row.update(spheres=_mean([x["n_spheres"] for x in s]),
                   fe_nodes=_mean([x["n_fe_nodes"] for x in s]),
                   bridging_spheres=_mean([x["n_bridging_spheres"] for x in s]),
                   steps=s[0]["steps"], dt=s[0]["dt"],
                   s_per_step=_mean([x["s_per_step"] for x in s]))
        if full:
            full_spheres = _mean([r.summary["n_spheres"] for r in full.values()])
            row["sphere_ratio"] = full_spheres / row["spheres"]
    row["warnings"] = {seed: s.get("warnings", []) for seed, (_, _, s) in done.items()
                       if seed not in limit}
    row["speedup"] = _speedup(done, runs, full, found.get(full_cfg, {}), timing)
    row["accuracy"] = _accuracy(runs, {seed: done[seed][0] for seed in runs}, full)
    row["goal"] = goal(c.scale, row, limit)
    return row


def _cost(done, full_members):
    """Wall seconds spent: every member, an automatic zone's failed attempts included."""
    walls = {seed: spent(s) for seed, (_, _, s) in done.items()}
    attempts = {seed: len(s["zone_attempts"]) for seed, (_, _, s) in done.items()
                if "zone_attempts" in s}
    full_walls = [spent(s) for _, (_, _, s) in full_members.items() if s is not None]
    out = {"wall_s": walls, "total_wall_s": float(sum(v for v in walls.values() if v)),
           "attempts": attempts or None}
    if full_walls and walls:
        out["against_full_run"] = {seed: w / np.mean(full_walls) for seed, w in walls.items()
                                   if w}
    projected = {seed: s["full_model_projected"]["wall_s"] for seed, (_, _, s) in done.items()
                 if "full_model_projected" in s}
    if projected:
        out["full_model_projected_wall_s"] = projected
    return out


def spent(summary):
    """Wall seconds a run took: an automatic zone's search (every attempt, its builds
    included), else the build and the steps."""
    if "zone_total_wall_s" in summary:
        return summary["zone_total_wall_s"]
    return summary.get("wall_s", 0.0) + summary.get("build_s", 0.0)


def _speedup(done, runs, full, full_members, timing):
    """Per-step speed-up: from the one-window timing when it holds both models, else from
    the runs' own time per step (each figure says where it comes from)."""
    out = {}
    seed = min(runs) if runs else None
    if timing and seed is not None:
        f_key = next((r.folder for _, (r, _, _) in sorted(full_members.items())), None)
        t_c = timing.get(done[seed][0].folder)
        t_f = timing.get(f_key) if f_key else None
        if t_c and t_f:
            out["timing"] = t_f["step_s"] / t_c["step_s"]
            out["timing_step_s"] = {"full": t_f["step_s"], "coupled": t_c["step_s"]}
    if runs and full:
        c_step = np.mean([done[k][2]["s_per_step"] for k in runs])
        f_step = np.mean([r.summary["s_per_step"] for r in full.values()])
        out["runs"] = float(f_step / c_step)
    source = "timing" if "timing" in out else "runs" if "runs" in out else None
    out["value"] = out.get(source)
    out["source"] = SPEEDUP_SOURCES.get(source)
    return out


def _accuracy(runs, planned, full):
    """Deviations against the full members at each coupled member's own sensors."""
    if not runs:
        return None
    if not full:
        return {"judged": False, "why": "no full run of this impact"}
    by_layout = {}
    for seed, run in runs.items():
        by_layout.setdefault(layout_label(planned[seed]), {})[seed] = run
    names = next(iter(runs.values())).names
    z = lambda r, cols: (r.t, r.h[:, [r.names.index(n) for n in cols], 2])
    sensors = {n: [] for n in names}
    paired = {n: [] for n in names}
    for label, members in by_layout.items():
        cols = full_names(label, names)
        lacking = [s for s, r in full.items() if not set(cols) <= set(r.names)]
        if lacking:
            return {"judged": False,
                    "why": f"the full run(s) of seed(s) {lacking} have no sensors at this "
                           f"zone's ({label or 'own'}): rerun them with its probes"}
        try:
            hist = ensemble.histories({s: z(r, cols) for s, r in full.items()},
                                      {s: z(r, names) for s, r in members.items()}, names)
        except ValueError as e:          # e.g. no common time window
            return {"judged": False, "why": f"not comparable with the full runs: {e}"}
        v = (verdicts.within_full_scatter(hist) if len(full) >= verdicts.MIN_FULL_MEMBERS
             else None)
        for n in names:
            sensors[n].append((hist, v["sensors"][n] if v else None))
            paired[n] += [x for x in hist["paired"][n]["nrms"]]
    dmg = ensemble.damage({s: r.summary["damage"] for s, r in full.items()},
                          {s: r.summary["damage"] for s, r in runs.items()})
    out = {"judged": len(full) >= verdicts.MIN_FULL_MEMBERS, "n_full": len(full),
           "weak": len(full) < verdicts.WEAK_BELOW, "sensors": {}, "damage": {}}
    for n in names:
        out["sensors"][n] = _sensor(sensors[n], paired[n], n)
    within = verdicts.damage_within_full_scatter(dmg) if out["judged"] else None
    for key in ensemble.DAMAGE_FIGURES:
        f = dmg["full"][key]
        out["damage"][key] = {
            "full_members": f["members"], "full_mean": f["mean"],
            "coupled_members": dmg["coupled_vs_full_mean"][key]["members"],
            "ratio_to_full_mean": dmg["coupled_vs_full_mean"][key]["ratio"],
            "paired_ratio": dmg["paired"][key]["ratio"],
            "verdict": within[key] if within else None}
    if not out["judged"]:
        out["why"] = (f"{len(full)} full run: a verdict against the full scatter needs "
                      f"{verdicts.MIN_FULL_MEMBERS}; the paired figures and the slab issue's "
                      f"absolute goals are given")
        out["absolute_goals"] = _absolute(out)
    return out


def _sensor(groups_, paired, name):
    """One sensor over the layouts of the members: the largest coupled deviation and, as
    the scatter it is judged against, each layout's own; within when every layout is."""
    nrms_v = [v["nrms"] if v else None for _, v in groups_]
    peak_v = [v["peak"] if v else None for _, v in groups_]
    hist = [h for h, _ in groups_]
    coupled_nrms = [x for h in hist for x in h["coupled_vs_full_mean"][name]["nrms"]]
    peak_ratio = [x for h in hist for x in h["coupled_vs_full_mean"][name]["peak_ratio"]]
    out = {"nrms_to_full_mean": coupled_nrms, "peak_ratio_to_full_mean": peak_ratio,
           "paired_nrms": paired,
           "full_nrms_leave_one_out": [h["full_scatter"][name]["nrms_leave_one_out"]
                                       for h in hist]}
    if all(v is not None for v in nrms_v):
        out["nrms"] = _combined(nrms_v)
        out["peak"] = _combined(peak_v)
        out["within"] = out["nrms"]["within"] and out["peak"]["within"]
        out["null_within"] = out["nrms"]["null_within"] or out["peak"]["null_within"]
    else:
        out["within"] = out["null_within"] = None
    return out


def _combined(vs):
    """Verdicts of several layouts as one: the largest coupled deviation, the smallest scatter
    (both as figures), within when each layout's verdict is."""
    c = [v["coupled_max"] for v in vs]
    f = [v["full_leave_one_out_max"] for v in vs]
    ok = all(x is not None for x in c + f)
    return {"coupled_max": max(c) if ok else None, "full_leave_one_out_max": min(f) if ok
            else None, "within": all(v["within"] for v in vs), "weak": any(v["weak"] for v in vs),
            "null_within": any(v.get("null_within") for v in vs), "n_full": vs[0]["n_full"]}


def _absolute(acc):
    """The slab issue's goals of each member against the full mean (one full run: itself)."""
    names = list(acc["sensors"])
    n = len(acc["sensors"][names[0]]["nrms_to_full_mean"])
    vol = acc["damage"]["damaged_volume_m3"]["ratio_to_full_mean"]
    return [verdicts.absolute_goals(
        {s: acc["sensors"][s]["nrms_to_full_mean"][i] for s in names},
        {s: acc["sensors"][s]["peak_ratio_to_full_mean"][i] for s in names}, vol[i])
        for i in range(n)]


def goal(scale, row, limit):
    """The issue's goal for one configuration: within the full scatter on every sensor and the
    damaged volume, and GOAL_SPEEDUP cheaper per step; `why` says what decided it."""
    need = GOAL_SPEEDUP[scale]
    acc, speed = row["accuracy"], row["speedup"]["value"]
    cheap = None if speed is None else speed >= need
    if limit:
        return {"qualifies": False, "within_scatter": None, "cheap_enough": cheap,
                "why": f"the automatic zone reached its limit on seed(s) {sorted(limit)}: "
                       f"coupling cannot pay for this impact"}
    if acc is None or not acc.get("judged"):
        why = "no finished run" if acc is None else acc["why"]
        return {"qualifies": None if cheap is not False else False, "within_scatter": None,
                "cheap_enough": cheap,
                "why": why if cheap is not False else f"{speed:.2f}x < {need:g}x per step; {why}"}
    outside = [n for n, s in acc["sensors"].items() if not s["within"]]
    volume = acc["damage"]["damaged_volume_m3"]["verdict"]["within"]
    if not volume:
        outside.append("damaged volume")
    within = not outside
    blind = [n for n, s in acc["sensors"].items() if s.get("null_within")]
    if acc["damage"]["damaged_volume_m3"]["verdict"].get("null_within"):
        blind.append("damaged volume")
    verdict = (f"outside the full scatter: {', '.join(outside)}" if outside else
               "within the full scatter" + (" (weak: 2 full runs)" if acc["weak"] else ""))
    if blind:
        verdict += (f" (a null prediction, no displacement or no damage, is within it too on: "
                    f"{', '.join(blind)})")
    speed_part = ("no per-step speed-up measured" if cheap is None else
                  f"{speed:.2f}x {'>=' if cheap else '<'} {need:g}x per step")
    return {"qualifies": within and bool(cheap), "within_scatter": within, "cheap_enough": cheap,
            "null_within": blind,
            "why": verdict + (", " if within and cheap else "; ") + speed_part}


def qualifying_configs(table, runs):
    """The planned fixed-zone configurations whose row in `table` qualifies."""
    rows = {(i["group"], r["config"]) for i in table["impacts"] for r in i["configs"]
            if r["goal"]["qualifies"]}
    return list(dict.fromkeys(r.config for r in runs if r.config.model == "coupled"
                              and r.config.zone != "auto"
                              and (r.config.group, r.config.name) in rows))


def choose(table):
    """The medium configuration the paper pair takes: the qualifying one with the largest
    speed-up (at the highest velocity where one qualifies); if none qualifies, None (the pair
    then measures the paper scale's own zone)."""
    best = None
    for impact in table["impacts"]:
        if impact["scale"] == "paper" or impact.get("reinforced"):   # the paper's slab is plain
            continue
        for row in impact["configs"]:
            if row["goal"]["qualifies"]:
                key = (impact["velocity"], row["speedup"]["value"])
                if best is None or key > best[0]:
                    best = (key, impact, row)
    if best is None:
        return None
    _, impact, row = best
    return Config("paper", impact["velocity"], "coupled", zone=row["zone"],
                  de_zone=row["de_zone_m"], full_width=row["full_width"], layers=row["layers"],
                  band_ratio=row.get("band_ratio"), fe_material=row.get("fe_material", "elastic"))


def _mean(values):
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def _first(summaries, key):
    return next((s.get(key) for s in summaries.values()), None)

