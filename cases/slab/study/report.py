"""What the study "where coupling pays" writes from its table (cases.slab.study.table):
table.md, one PNG per impact (each sensor's and the damaged volume's deviation against the
per-step speed-up, the full scatter as a band), and the docs page with the paper's Table 1 row
and the projection to 100,000 steps."""
from common.files import save_figure, write_text
from cases.slab.study.plan import REINFORCED_ROWS

PAPER_STEPS = 100_000
SENSORS = ("under_impact", "de_zone", "bridging", "fe_node")


def _f(x, fmt="{:.3f}"):
    return "–" if x is None else fmt.format(x)


def _yes(x):
    return "–" if x is None else ("yes" if x else "**no**")


def sensor_cell(s):
    """'nRMS / scatter ✓' of one sensor (the largest coupled nRMS to the full mean against
    the largest leave-one-out nRMS of a full member)."""
    if s is None or s.get("within") is None:
        return _f(max((x for x in (s or {}).get("nrms_to_full_mean", []) if x is not None),
                      default=None))
    n = s["nrms"]
    if n["coupled_max"] is None:
        return "undefined (no peak): **outside**"
    mark = "within" if s["within"] else "**outside**"
    return f"{_f(n['coupled_max'])} / {_f(n['full_leave_one_out_max'])} {mark}"


def damage_cell(acc):
    if not acc or "damage" not in acc:
        return "–"
    d = acc["damage"]["damaged_volume_m3"]
    v = d["verdict"]
    ratios = ", ".join(_f(r) for r in d["ratio_to_full_mean"])
    if v is None:
        return f"ratio {ratios}"
    return (f"ratio {ratios}: {_f(v['coupled_max'])} / {_f(v['full_leave_one_out_max'])} "
            f"{'within' if v['within'] else '**outside**'}")


def checks_cell(row):
    """The paper's a-posteriori checks of the first seed (the run's post-run warnings)."""
    w = row.get("warnings") or {}
    if not w:
        return "–"
    seed = min(w)
    text = "; ".join(x.split(": the DE zone")[0] for x in w[seed]) or "passed"
    return text + (f" (seed {seed})" if len(w) > 1 else "")


def config_line(row):
    return "| " + " | ".join(config_cells(row)) + " |"


def config_cells(row):
    acc = row["accuracy"] or {}
    sensors = acc.get("sensors", {})
    sp = row["speedup"]
    speed = ("–" if sp["value"] is None else
             f"{sp['value']:.2f} ({'timed' if 'timing' in sp else 'runs'})")
    cost = row["cost"]
    attempts = cost.get("attempts")
    spent = f"{cost['total_wall_s']:.0f}" + (
        f" ({sum(attempts.values())} attempts)" if attempts else "")
    cells = [row["config"], ",".join(map(str, row["seeds"])) or "–",
             _f(row.get("spheres"), "{:.0f}"), _f(row.get("sphere_ratio"), "{:.2f}"), speed]
    cells += [sensor_cell(sensors.get(n)) for n in SENSORS]
    cells += [damage_cell(acc), checks_cell(row), spent,
              ("**yes**" if row["goal"]["qualifies"] else "no" if row["goal"]["qualifies"]
               is False else "undetermined") + f": {row['goal']['why']}"]
    return cells


HEADER_CELLS = (["configuration", "seeds", "spheres", "sphere ratio", "speed-up per step"]
                + [f"{n}: nRMS / scatter" for n in SENSORS]
                + ["damaged volume: deviation / scatter", "post-run checks", "wall s spent",
                   "goal"])
HEADER = ("| " + " | ".join(HEADER_CELLS) + " |\n|" + "---|" * len(HEADER_CELLS) + "\n")


def impact_title(impact):
    return (f"{impact['scale']} scale, {impact['velocity']:g} m/s"
            + (", reinforced" if impact.get("reinforced") else ""))


def markdown(table):
    """table.md: one table per impact."""
    lines = ["# Where coupling pays: the table", "",
             "Per configuration: the largest nRMS of a coupled member against the full "
             "ensemble's mean history, over the largest leave-one-out nRMS of a full member "
             "(the scatter; orchestrator/verdicts.py), the damaged volume likewise (its "
             "deviation: the ratio to the full mean less 1, in absolute value), the per-step "
             "speed-up (timed: one window of each model on CPU time, "
             "bench.worker; runs: the runs' own wall time), the wall time spent (an automatic "
             "zone's failed attempts included) and the goal (within the scatter on every "
             "sensor, nRMS and peak, and the damaged volume, and ≥ 5× cheaper per step at "
             "medium scale, 10× at paper scale).", ""]
    for impact in table["impacts"]:
        f = impact["full"]
        lines += [f"## {impact_title(impact)}", "",
                  f"Full ensemble: seeds {', '.join(map(str, f['seeds'])) or 'none'}"
                  + (f" (missing: {f['missing']})" if f["missing"] else "")
                  + (f", {f['spheres']:.0f} spheres, {f['steps']} steps of {f['dt']:.4g} s, "
                     f"wall {', '.join(f'{w:.0f}' for w in f['wall_s'])} s"
                     if f.get("spheres") else ""), "", HEADER.rstrip("\n")]
        lines += [config_line(row) for row in impact["configs"]]
        lines.append("")
    if table.get("table1"):
        lines += table1_lines(table["table1"])
    return "\n".join(lines) + "\n"


def table1(table):
    """The paper's Table 1 row of the paper pair (coupled and full), with the projection to
    100,000 steps; None without a finished paper pair."""
    paper = next((i for i in table["impacts"] if i["scale"] == "paper"), None)
    if paper is None or not paper["configs"] or paper["configs"][0].get("spheres") is None:
        return None
    row, f = paper["configs"][0], paper["full"]
    sp = row["speedup"]
    t_c = sp.get("timing_step_s", {}).get("coupled")
    t_f = sp.get("timing_step_s", {}).get("full")
    c_step = row["s_per_step"]
    return {"velocity": paper["velocity"], "config": row["config"],
            "coupled": {"spheres": row["spheres"], "fe_nodes": row["fe_nodes"],
                        "n_b": row["layers"], "bridging_spheres": row["bridging_spheres"],
                        "steps": row["steps"], "dt": row["dt"],
                        "wall_s": row["cost"]["total_wall_s"] / len(row["seeds"]),
                        "projected_100k_steps_s": {"timed": None if t_c is None
                                                   else PAPER_STEPS * t_c,
                                                   "run": PAPER_STEPS * c_step}},
            "full": {"spheres": f.get("spheres"), "steps": f.get("steps"),
                     "wall_s": f["wall_s"][0] if f.get("wall_s") else None,
                     "projected_100k_steps_s": {
                         "timed": None if t_f is None else PAPER_STEPS * t_f,
                         "run": PAPER_STEPS * f["s_per_step"][0] if f.get("s_per_step")
                         else None}},
            "speedup": sp, "goal": row["goal"],
            "absolute_goals": (row["accuracy"] or {}).get("absolute_goals")}


def table1_lines(t):
    c, f = t["coupled"], t["full"]
    h = lambda s: "–" if s is None else f"{s / 3600:.2f} h"
    return [f"## The paper's Table 1 row ({t['velocity']:g} m/s, {t['config']})", "",
            "| model | spheres | FE nodes | n_b | steps | time (wall) | 100,000 steps: timed "
            "/ from the run |", "|---|---|---|---|---|---|---|",
            f"| coupled | {c['spheres']:.0f} | {c['fe_nodes']:.0f} | {c['n_b']} | {c['steps']} | "
            f"{c['wall_s']:.0f} s | {h(c['projected_100k_steps_s']['timed'])} / "
            f"{h(c['projected_100k_steps_s']['run'])} |",
            f"| full | {_f(f['spheres'], '{:.0f}')} | 0 | – | {f['steps']} | "
            f"{_f(f['wall_s'], '{:.0f}')} s | {h(f['projected_100k_steps_s']['timed'])} / "
            f"{h(f['projected_100k_steps_s']['run'])} |", ""]


def plot_impact(impact, path):
    """One panel per sensor and one for the damaged volume: each configuration's largest
    deviation from the full mean (marker) against its per-step speed-up, over a grey band
    from 0 to the full scatter that judges it; the goal's speed-up as a dashed line."""
    from cases.slab.study.table import GOAL_SPEEDUP
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter
    panels = list(SENSORS) + ["damaged volume"]
    fig, grid = plt.subplots(2, 3, figsize=(13, 7.5), sharex=True)
    axes, key = grid.ravel()[:len(panels)], grid.ravel()[-1]
    rows = [r for r in impact["configs"] if r["speedup"]["value"] is not None
            and (r["accuracy"] or {}).get("judged")]
    for ax, name in zip(axes, panels):
        for k, row in enumerate(rows):
            acc, x = row["accuracy"], row["speedup"]["value"]
            if name in acc["sensors"]:
                v = acc["sensors"][name].get("nrms")
            else:
                v = acc["damage"]["damaged_volume_m3"]["verdict"]
            if v is None or v["coupled_max"] is None:      # undefined: no peak, no damage
                continue
            ax.bar(x, v["full_leave_one_out_max"], width=0.06 * x, color="0.8",
                   label="full scatter" if k == 0 else None)
            ax.plot(x, v["coupled_max"], "o" if v["within"] else "x", color=f"C{k % 10}",
                    label=row["config"])
        ax.axvline(GOAL_SPEEDUP[impact["scale"]], ls="--", color="k", lw=1)
        ax.set(xscale="log", title=name, xlabel="speed-up per step",
               ylabel="nRMS to the full mean" if name in SENSORS else "|ratio to the mean − 1|")
        top = max([r["speedup"]["value"] for r in rows] + [GOAL_SPEEDUP[impact["scale"]]])
        ax.set_xlim(0.8, 1.5 * top)
        ax.set_xticks([t for t in (1, 2, 5, 10, 20, 50) if t <= 1.5 * top])
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    key.axis("off")
    handles, labels = axes[0].get_legend_handles_labels()
    if rows:
        key.legend(handles, labels, loc="center", fontsize="small")
    else:
        key.text(0.5, 0.5, "no judged configuration", ha="center")
    fig.suptitle(f"{impact_title(impact)}: error against speed-up (o within the full "
                 f"scatter, x outside; dashed: the goal)")
    fig.tight_layout()
    save_figure(fig, path)


def qualifying(table):
    """[(impact, row)] of the configurations that meet the goal."""
    return [(i, r) for i in table["impacts"] for r in i["configs"] if r["goal"]["qualifies"]]


def doc(table, runs, outcomes, projected_s, sweep, images, command):
    """The study's page (markdown), written whole from the table: the runs made, what qualifies
    (or "none at this resolution", with the figures), the paper pair and its Table 1 row."""
    lines = ["# Where coupling pays", "",
             f"Written by `{command}` (sweep `{sweep}`) from `table.json`; every figure below "
             "is in that table. Per configuration of each impact: each sensor's nRMS and peak "
             "against the full ensemble's scatter between packing seeds (the largest coupled "
             "deviation against the largest leave-one-out deviation of a full member: "
             "orchestrator/verdicts.py), the damaged volume likewise, the per-step speed-up, "
             "the sphere ratio and the wall time spent. The goal: within the full "
             "scatter on every sensor and the damaged volume, and at least 5× cheaper per "
             "step at medium scale, 10× at paper scale.", ""]
    lines += (_claim_lines(table) + _method_lines(_last_state_runs(runs, outcomes))
              + _run_lines(runs, outcomes, projected_s))
    lines += _map_lines(table, images) + _paper_lines(table)
    return "\n".join(lines) + "\n"


def _claim_lines(table):
    lines = ["## Where the claim holds", ""]
    q = qualifying(table)
    if q:
        for impact, row in q:
            checks = checks_cell(row)
            lines.append(f"- **{impact_title(impact)}, {row['config']}** (seeds "
                         f"{', '.join(map(str, row['seeds']))}): {row['goal']['why']}"
                         + ("" if checks in ("–", "passed") else
                            f"; the paper's post-run checks: {checks}"))
    else:
        lines.append("**None at this resolution.** No configuration of the map lies within "
                     "the full scatter and is cheap enough; per impact, the closest:")
        lines.append("")
        for impact in table["impacts"]:
            for row in impact["configs"]:
                sp = row["speedup"]["value"]
                lines.append(f"- {impact_title(impact)}, {row['config']}: "
                             f"{'–' if sp is None else f'{sp:.2f}x'} per step; "
                             f"{row['goal']['why']}")
    return lines + ["", f"Reinforced concrete: {REINFORCED_ROWS}.", ""]


def _last_state_runs(runs, outcomes):
    """(coupled runs written before the FE's peak stress was recorded: their post-run FE
    check read the last state, coupled runs finished)."""
    done = [o.summary for r in runs if r.config.model == "coupled"
            and (o := outcomes.get(r.folder)) is not None and o.summary is not None
            and "n_spheres" in o.summary]
    return sum("fe_peak_stress" not in s for s in done), len(done)


def _method_lines(last_state):
    old, done = last_state
    return ["## How it is measured", "",
            "- A coupled model places its sensors by its own DE zone and band; the full "
            "model's physics does not depend on the zone, so each full member records, "
            "beside its own sensors, those of every coupled zone of its impact (the "
            "automatic zones' final ones included) and each coupled member is judged at its "
            "own sensors (cases/slab/probes.py).",
            "- The per-step speed-up is timed, when the table says `timed`, on one window "
            "of each model built afresh from its run's description, one after the other, in "
            "CPU time (bench/study_timing.py: at medium scale 0.2 ms into the impact, at "
            "paper scale right after the build); the runs' own wall times per step are "
            "kept beside it (`runs`): on a loaded machine they gave 0.46-2.57 for the same "
            "pair of models.",
            "- The automatic zone is run on seed 1, and on seeds 2 and 3 only when seed 1 "
            "ends clean (default sweep); its cost is every attempt's wall time. A fixed zone "
            "that qualifies on seed 1 is run on seeds 2 and 3 too and judged on all three.",
            "- A scatter can be too wide to judge: each verdict also says whether a null "
            "prediction (a displacement that stays at zero, no damage) would lie within it "
            "(its deviation is exact: 1 for a peak or the damaged volume, rms / peak of the "
            "full mean for an nRMS). The goal's line names such figures: they are no "
            "evidence for the coupled model.",
            "- Post-run checks: the paper's two a-posteriori checks, made at the end of each "
            "run: the FE's peak stress over the run in the cells outside the bridging band "
            "(`fe_peak_stress`, read at every sensor sample) against the concrete's "
            "strengths, and the damaged bridging spheres, as the run's `summary.json` warns."
            + (f" {old} of the {done} coupled runs here were written before the peak was "
               "recorded: their FE figure is the stress of their last state, which a peak "
               "passing earlier can exceed." if old else ""),
            "- The default plan is chosen for about 3 h of one core (the projection below, "
            "from bench/results.json): 10 and 40 m/s, the zones × n_b sweep at 10 m/s; "
            "`--sweep full` runs 10, 20 and 40 m/s, the sweep at each, the default and "
            "automatic zones on three seeds and two paper seeds.", ""]


def _run_lines(runs, outcomes, projected_s):
    lines = ["## The runs", "",
             f"Projected cost of the plan on one quiet core: {projected_s / 3600:.2f} h "
             f"(bench/results.json). Each run is a `slab` run in its folder of "
             f"`results/where-coupling-pays/`.", "",
             "| run | seed | steps | status | wall s |", "|---|---|---|---|---|"]
    for r in runs:
        o = outcomes.get(r.folder)
        s = o.summary if o else None
        wall = None if s is None else s.get("zone_total_wall_s", s.get("wall_s"))
        lines.append(f"| {r.config.folder} | {r.seed} | {r.spec().steps} | "
                     f"{o.status if o else 'not run'} | {_f(wall, '{:.0f}')} |")
    return lines + [""]


def _map_lines(table, images):
    lines = ["## The map", ""]
    for impact in table["impacts"]:
        lines += [f"### {impact_title(impact)}", "", HEADER.rstrip("\n")]
        lines += [config_line(row) for row in impact["configs"]]
        if impact["group"] in images:
            lines += ["", f"![{impact_title(impact)}]({images[impact['group']]})"]
        lines.append("")
    return lines


def _paper_lines(table):
    t1 = table.get("table1")
    if not t1:
        return ["Paper scale: not run yet."]
    lines = table1_lines(t1) + [f"Paper pair: {t1['goal']['why']}."]
    for goals in t1.get("absolute_goals") or []:
        lines.append("Against the full run, the slab issue's goals: " + ", ".join(
            f"{k.replace('_', ' ')}: {_yes(v)}" for k, v in goals.items()) + ".")
    return lines


def write(table, out, page_name, page_text):
    """The study's folder `out`: table.json, table.md, report.html and the page (doc)."""
    from common.files import write_json
    write_json(out / "table.json", table)
    write_text(out / "table.md", markdown(table))
    page(table, out)
    write_text(out / page_name, page_text)


def page(table, out):
    """out/report.html: the table of each impact (table.md's cells, its bold shown red), its
    picture, what qualifies, and the paper's Table 1 row."""
    from common.html import heading, items, paragraph, picture, table as html_table, write_page

    def cell(text):
        return (text.replace("**", ""), "bad") if "**" in text else text
    found = [f"{impact_title(impact)}: {row['config']} ({row['goal']['why']})"
             for impact, row in qualifying(table)]
    blocks = [heading("Where coupling pays"),
              items(found) if found else paragraph("No configuration qualifies at this "
                                                   "resolution.")]
    for impact in table["impacts"]:
        blocks += [heading(impact_title(impact)),
                   html_table(HEADER_CELLS, [[cell(c) for c in config_cells(row)]
                                             for row in impact["configs"]],
                              f"impact-{impact['group']}")]
        if impact["scale"] != "paper":
            blocks.append(picture(out / f"{impact['group']}.png",
                                  f"{impact_title(impact)}: deviation against speed-up, the "
                                  f"full scatter as a band"))
    t = table.get("table1")
    if t:
        hours = lambda s: "–" if s is None else f"{s / 3600:.2f}"
        rows = [[name, _f(m["spheres"], "{:.0f}"), fe, layers, m["steps"],
                 _f(m["wall_s"], "{:.0f}"), hours(m["projected_100k_steps_s"]["timed"]),
                 hours(m["projected_100k_steps_s"]["run"])]
                for name, m, fe, layers in (("coupled", t["coupled"], t["coupled"]["fe_nodes"],
                                             t["coupled"]["n_b"]), ("full", t["full"], 0, "–"))]
        blocks += [heading(f"The paper's Table 1 row ({t['velocity']:g} m/s, {t['config']})"),
                   html_table(["model", "spheres", "FE nodes", "n_b", "steps", "wall s",
                               "100,000 steps, timed (h)", "100,000 steps, from the run (h)"],
                              rows, "table1")]
    return write_page(out / "report.html", "study: where coupling pays", blocks)
