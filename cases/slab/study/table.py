"""The table of the study "where coupling pays", from its run folders: per coupled zone of each
impact, the yardstick's judgement against the impact's full ensemble (cases.slab.judge on the
quantities of interest and the cracking energy, as `compare` gives it), the per-step speed-up
and the sphere ratio, the wall time spent (a grown zone's conversions included), and the
goal: every statistic equivalent, and at least GOAL_SPEEDUP cheaper per step. A statistic
that cannot judge or is not judged leaves the goal undecided, never met."""
import numpy as np

from cases.slab import compare, judge
from cases.slab.study.plan import Config, where

GOAL_SPEEDUP = {"small": 5.0, "medium": 5.0, "paper": 10.0}   # per step, the slab issue's
SPEEDUP_SOURCES = {
    "timing": "timed back to back on CPU time, one window of each model in its own process "
              "(bench.worker; timing.json)",
    "runs": "the runs' own wall time per step (separate runs: unreliable on a loaded machine, "
            "0.46-2.57 measured for the same pair of models)",
}


def groups(runs):
    """{group: {config: [planned]}} in plan order; each group's full configuration first
    (plan.impact)."""
    out = {}
    for r in runs:
        out.setdefault(r.config.group, {}).setdefault(r.config, []).append(r)
    return out


def build(runs, out, index=None, timing=None):
    """The table: {"impacts": [{"group", "scale", "velocity", "reinforced", "full": {...},
    "configs": [...]}]} of the planned `runs` found in `out` (or among the reused ensembles
    `index`); `timing`: the one-window timing ({run folder: bench figures}), else the runs'
    own."""
    impacts = []
    for group, configs in groups(runs).items():
        found = {c: {r.seed: (r, *where(r, out, index or {})) for r in rs}
                 for c, rs in configs.items()}
        full_cfg = next(c for c in configs if c.model == "full")
        full = _finished(found[full_cfg])
        impacts.append({"group": group, "scale": full_cfg.scale, "velocity": full_cfg.velocity,
                        "reinforced": full_cfg.reinforced,
                        "full": _full_figures(found[full_cfg]),
                        "configs": [config_row(c, members, full, timing)
                                    for c, members in found.items() if c.model != "full"]})
    return {"impacts": impacts}


def _finished(members):
    """{seed: (planned, folder, summary)} of the members that finished."""
    return {seed: m for seed, m in sorted(members.items()) if m[2] is not None}


def _full_figures(members):
    done = _finished(members)
    s = [x for _, _, x in done.values()]
    return {"seeds": sorted(done), "missing": sorted(set(members) - set(done)),
            "folders": {seed: str(f) for seed, (_, f, _) in done.items()},
            "spheres": mean([x["n_spheres"] for x in s]),
            "steps": s[0]["steps"] if s else None, "dt": s[0]["dt"] if s else None,
            "wall_s": [spent(x) for x in s], "s_per_step": [x["s_per_step"] for x in s]}


def config_row(c, members, full_members, timing):
    """The figures of one coupled configuration (members: {seed: (planned, folder,
    summary)}, full_members: its impact's finished full ones)."""
    done = _finished(members)
    row = {"config": c.name, "zone": c.zone, "de_zone_m": c.de_zone,
           "seeds": sorted(done), "missing": sorted(set(members) - set(done)),
           "folders": {seed: str(f) for seed, (_, f, _) in done.items()},
           "cost": _cost(done, full_members)}
    limit = [seed for seed, (_, _, s) in done.items() if s.get("zone_outcome") == "limit"]
    row["zone_limit_seeds"] = limit
    if limit:
        row["zone_message"] = done[limit[0]][2].get("zone_message")
    judged = {seed: m for seed, m in done.items() if seed not in limit}
    if judged:
        s = [x for _, _, x in judged.values()]
        row.update(spheres=mean([x["n_spheres"] for x in s]),
                   fe_nodes=mean([x["n_fe_nodes"] for x in s]),
                   bridging_spheres=mean([x["n_bridging_spheres"] for x in s]),
                   layers=s[0]["spec"]["layers"], steps=s[0]["steps"], dt=s[0]["dt"],
                   s_per_step=mean([x["s_per_step"] for x in s]),
                   conversions=[len(x.get("zone_conversions", [])) for x in s])
        full_spheres = mean([x["n_spheres"] for _, _, x in full_members.values()])
        if full_spheres is not None:
            row["sphere_ratio"] = full_spheres / row["spheres"]
    row["warnings"] = {seed: s.get("warnings", []) for seed, (_, _, s) in judged.items()}
    row["speedup"] = _speedup(judged, full_members, timing)
    row["judged"] = _judged(judged, full_members)
    row["goal"] = goal(c.scale, row)
    return row


def _judged(done, full):
    """The yardstick on the finished members: {"judgement", "headline", "equivalent",
    "total", "failures"}, or {"why"} when it cannot be applied."""
    if not done:
        return {"why": "no finished coupled run"}
    if not full:
        return {"why": "no finished full run of this impact"}
    try:
        f, c = compare.load([x[1] for x in full.values()], [x[1] for x in done.values()],
                            verdict=True)
        j = compare.judgement(f, c)
    except (OSError, ValueError) as e:
        return {"why": f"not comparable with the full runs: {e}"}
    fails, equivalent = judge.failures(j)
    return {"judgement": j, "headline": judge.headline(j), "equivalent": equivalent,
            "total": equivalent + sum(map(len, fails.values())),
            "failures": {kind: [x if kind == judge.NOT_JUDGED else judge.described(j, x)
                                for x in judge.named(kind, labels)]
                         for kind, labels in fails.items()}}


def _cost(done, full_members):
    """Wall seconds spent: every member, a grown zone's conversions included."""
    walls = {seed: spent(s) for seed, (_, _, s) in done.items()}
    full_walls = [w for w in (spent(s) for _, _, s in full_members.values()) if w]
    known = [w for w in walls.values() if w is not None]
    out = {"wall_s": walls, "total_wall_s": float(sum(known)) if known else None}
    if full_walls and walls:
        out["against_full_run"] = {seed: w / np.mean(full_walls) for seed, w in walls.items()
                                   if w}
    return out


def spent(summary):
    """Wall seconds a run took: its build and its steps, a grown zone's conversions included;
    one stopped at its limit, up to there, and its fallback's (None: not recorded, a run
    stopped before the record was kept)."""
    parts = [summary[k] for k in ("zone_wall_s", "wall_s", "build_s") if k in summary]
    return float(sum(parts)) if parts else None


def _speedup(done, full, timing):
    """Per-step speed-up: from the one-window timing when it holds both models, else from
    the runs' own time per step (each figure says where it comes from)."""
    out = {}
    if timing and done and full:
        t_c = timing.get(next(iter(done.values()))[0].folder)
        t_f = timing.get(next(iter(full.values()))[0].folder)
        if t_c and t_f:
            out["timing"] = t_f["step_s"] / t_c["step_s"]
            out["timing_step_s"] = {"full": t_f["step_s"], "coupled": t_c["step_s"]}
    if done and full:
        out["runs"] = float(np.mean([s["s_per_step"] for _, _, s in full.values()])
                            / np.mean([s["s_per_step"] for _, _, s in done.values()]))
    source = "timing" if "timing" in out else "runs" if "runs" in out else None
    out["value"] = out.get(source)
    out["source"] = SPEEDUP_SOURCES.get(source)
    return out


def goal(scale, row):
    """The goal for one configuration: {"qualifies": True | False | None (undecided),
    "equivalent", "cheap_enough", "why"}: every statistic equivalent and GOAL_SPEEDUP cheaper
    per step; any statistic not equivalent, or too slow, fails it; one that cannot judge or
    is not judged leaves it undecided."""
    need = GOAL_SPEEDUP[scale]
    speed = row["speedup"]["value"]
    cheap = None if speed is None else bool(speed >= need)
    speed_part = ("no per-step speed-up measured" if cheap is None else
                  f"{speed:.2f}x {'>=' if cheap else '<'} {need:g}x per step")
    if row["zone_limit_seeds"]:
        return {"qualifies": False, "equivalent": None, "cheap_enough": cheap,
                "why": f"cannot pay: the grown zone reached its limit on seed(s) "
                       f"{', '.join(map(str, row['zone_limit_seeds']))}"}
    j = row["judged"]
    if "judgement" not in j:
        equivalent, verdict = None, j["why"]
    else:
        counts = {kind: len(labels) for kind, labels in judge.failures(j["judgement"])[0].items()}
        equivalent = (False if counts["not equivalent"] else None if any(counts.values())
                      else True)
        verdict = (f"equivalent on all {j['total']}" if equivalent else
                   ", ".join(f"{n} {kind}" for kind, n in counts.items() if n)
                   + f" of {j['total']}")
    qualifies = (False if equivalent is False or cheap is False else
                 True if equivalent and cheap else None)
    return {"qualifies": qualifies, "equivalent": equivalent, "cheap_enough": cheap,
            "why": f"{verdict}; {speed_part}"}


def choose(table):
    """{velocity: Config} the paper part takes: at each medium velocity the plain slab's
    configuration that qualifies with the largest speed-up (none: the paper scale's grown
    zone)."""
    best = {}
    for impact in table["impacts"]:
        if impact["scale"] == "paper" or impact["reinforced"]:     # the paper's slab is plain
            continue
        for row in impact["configs"]:
            v = impact["velocity"]
            if row["goal"]["qualifies"] and (v not in best or row["speedup"]["value"]
                                             > best[v][0]):
                best[v] = (row["speedup"]["value"],
                           Config("paper", v, "coupled", zone=row["zone"],
                                  de_zone=row["de_zone_m"]))
    return {v: c for v, (_, c) in best.items()}


def mean(values):
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None
