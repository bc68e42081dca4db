"""What the study "where coupling pays" writes from its table (cases.slab.study.table):
table.md, one PNG per impact (each configuration's peak differences from the full mean with
their intervals, against the margin), report.html, and the docs page with the paper's Table 1
row and the projection to 100,000 steps."""
from common.files import save_figure, write_text
from cases.slab import judge
from cases.slab.study.table import mean, spent

PAPER_STEPS = 100_000
HEADER_CELLS = ["zone", "seeds", "spheres", "sphere ratio", "speed-up per step", "equivalent",
                "cannot judge", "not judged", "not equivalent", "post-run checks",
                "wall s spent", "goal"]
HEADER = ("| " + " | ".join(HEADER_CELLS) + " |\n|" + "---|" * len(HEADER_CELLS) + "\n")


def _f(x, fmt="{:.3f}"):
    return "–" if x is None else fmt.format(x)


def checks_cell(row):
    """The paper's a-posteriori checks of the first seed (the run's post-run warnings)."""
    w = row.get("warnings") or {}
    if not w:
        return "–"
    seed = min(w)
    text = "; ".join(x.split(": the DE zone")[0] for x in w[seed]) or "passed"
    return text + (f" (seed {seed})" if len(w) > 1 else "")


def zone_cell(row):
    """The zone, and what a grown one did: its conversions per seed, or its limit."""
    if row["zone"] != "grow":
        return row["config"]
    if row["zone_limit_seeds"]:
        return (f"grown: **cannot pay** on seed(s) "
                f"{', '.join(map(str, row['zone_limit_seeds']))}")
    conversions = row.get("conversions") or []
    return "grown" + (f" ({min(conversions)}-{max(conversions)} conversions)"
                      if conversions else "")


def config_cells(row):
    j = row["judged"]
    sp = row["speedup"]
    speed = ("–" if sp["value"] is None else
             f"{sp['value']:.2f} ({'timed' if 'timing' in sp else 'runs'})")
    if "judgement" in j:
        f = j["failures"]
        verdicts = [f"{j['equivalent']} of {j['total']}", str(len(f["cannot judge"])),
                    ", ".join(f[judge.NOT_JUDGED]) or "–",
                    "**" + "; ".join(f["not equivalent"]) + "**" if f["not equivalent"]
                    else "none"]
    else:
        verdicts = [j["why"], "–", "–", "–"]
    return ([zone_cell(row), ",".join(map(str, row["seeds"])) or "–",
             _f(row.get("spheres"), "{:.0f}"), _f(row.get("sphere_ratio"), "{:.2f}"), speed]
            + verdicts
            + [checks_cell(row), _f(row["cost"]["total_wall_s"], "{:.0f}"),
               f"{outcome(row['goal'], '**yes**')}: {row['goal']['why']}"])


def outcome(goal, yes="yes"):
    """The goal's outcome in a word."""
    q = goal["qualifies"]
    return yes if q else "no" if q is False else "undecided"


def config_line(row):
    return "| " + " | ".join(config_cells(row)) + " |"


def impact_title(impact):
    return (f"{impact['scale']} scale, {impact['velocity']:g} m/s"
            + (", reinforced" if impact.get("reinforced") else ""))


def _full_line(impact):
    f = impact["full"]
    return (f"Full ensemble: seeds {', '.join(map(str, f['seeds'])) or 'none'}"
            + (f" (missing: {f['missing']})" if f["missing"] else "")
            + (f", {f['spheres']:.0f} spheres, {f['steps']} steps of {f['dt']:.4g} s, wall "
               f"{', '.join(_f(w, '{:.0f}') for w in f['wall_s'])} s" if f.get("spheres")
               else ""))


MEASURE = ("Per zone: the yardstick's statistics (docs/slab.md, \"How a comparison is "
           "judged\": the quantities of interest and the cracking energy of the coupled "
           "members against the full ones of the same seeds, an equivalence test with margins "
           "stated before the runs), the per-step speed-up (timed: one window of each model on "
           "CPU time, bench.worker; runs: the runs' own wall time), the wall time spent (a "
           "grown zone's conversions included) and the goal: every statistic equivalent and "
           "at least 5× cheaper per step at small and medium scale, 10× at paper scale. A "
           "statistic that cannot judge or is not judged leaves the goal undecided; a grown "
           "zone at its limit says coupling cannot pay.")


def markdown(table):
    """table.md: one table per impact."""
    lines = ["# Where coupling pays: the table", "", MEASURE, ""]
    for impact in table["impacts"]:
        lines += [f"## {impact_title(impact)}", "", _full_line(impact), "",
                  HEADER.rstrip("\n")]
        lines += [config_line(row) for row in impact["configs"]]
        lines.append("")
    if table.get("table1"):
        lines += table1_lines(table["table1"])
    return "\n".join(lines) + "\n"


def table1(table):
    """The paper's Table 1 row of the first judged paper configuration (coupled and full),
    with the projection to 100,000 steps; None without one."""
    found = [(i, r) for i in table["impacts"] if i["scale"] == "paper" for r in i["configs"]
             if r.get("spheres") is not None and i["full"].get("spheres") is not None]
    if not found:
        return None
    paper, row = found[0]
    f, sp = paper["full"], row["speedup"]
    t_c = sp.get("timing_step_s", {}).get("coupled")
    t_f = sp.get("timing_step_s", {}).get("full")
    projected = lambda step: None if step is None else PAPER_STEPS * step    # noqa: E731
    return {"velocity": paper["velocity"], "config": row["config"],
            "coupled": {"spheres": row["spheres"], "fe_nodes": row["fe_nodes"],
                        "n_b": row["layers"], "bridging_spheres": row["bridging_spheres"],
                        "steps": row["steps"], "dt": row["dt"],
                        "wall_s": mean(row["cost"]["wall_s"].values()),
                        "projected_100k_steps_s": {"timed": projected(t_c),
                                                   "run": projected(row["s_per_step"])}},
            "full": {"spheres": f["spheres"], "steps": f["steps"], "wall_s": f["wall_s"][0],
                     "projected_100k_steps_s": {"timed": projected(t_f),
                                                "run": projected(f["s_per_step"][0])}},
            "speedup": sp, "goal": row["goal"]}


def _table1_rows(t):
    c, f = t["coupled"], t["full"]
    hours = lambda s: "–" if s is None else f"{s / 3600:.2f} h"      # noqa: E731
    return [[name, _f(m["spheres"], "{:.0f}"), fe, n_b, m["steps"], _f(m["wall_s"], "{:.0f}"),
             hours(m["projected_100k_steps_s"]["timed"]),
             hours(m["projected_100k_steps_s"]["run"])]
            for name, m, fe, n_b in (("coupled", c, f"{c['fe_nodes']:.0f}", c["n_b"]),
                                     ("full", f, "0", "–"))]


TABLE1_HEADER = ["model", "spheres", "FE nodes", "n_b", "steps", "wall s",
                 "100,000 steps, timed", "100,000 steps, from the run"]


def table1_lines(t):
    return ([f"## The paper's Table 1 row ({t['velocity']:g} m/s, {t['config']})", "",
             "| " + " | ".join(TABLE1_HEADER) + " |", "|" + "---|" * len(TABLE1_HEADER)]
            + ["| " + " | ".join(map(str, r)) + " |" for r in _table1_rows(t)]
            + ["", f"Paper scale: {t['goal']['why']}.", ""])


def plot_impact(impact, path):
    """Each judged configuration's difference from the full mean on every peak and total
    (the coupled minus the full mean, relative to it) with its interval, against ±the margin:
    a forest of the equivalence tests (o equivalent, x not equivalent, + cannot judge; a
    statistic cut by the window is marked "not judged")."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = [r for r in impact["configs"] if "judgement" in r["judged"]]
    names = [(q, s) for q, stats in (rows[0]["judged"]["judgement"]["qoi"].items()
                                     if rows else []) for s in ("peak", "total") if s in stats]
    fig, ax = plt.subplots(figsize=(9, 1.2 + 0.45 * max(len(names), 1)))
    marks = {"equivalent": "o", "not equivalent": "x", "cannot judge": "+"}
    for k, row in enumerate(rows):
        qoi = row["judged"]["judgement"]["qoi"]
        label = row["config"]
        for y, (q, s) in enumerate(names):
            r = qoi[q][s]
            if "interval" not in r:          # not judged: cut by the window
                ax.annotate("not judged", (0, y), color="0.5", fontsize=7, ha="center",
                            va="center")
                continue
            off = y + 0.15 * (k - (len(rows) - 1) / 2)
            ax.plot([100 * r["interval"][0], 100 * r["interval"][1]], [off, off], "-",
                    color=f"C{k % 10}", lw=1.5)
            ax.plot(100 * r["difference"], off, marks[r["verdict"]], color=f"C{k % 10}",
                    label=label)
            label = None
    if rows:
        margin = 100 * rows[0]["judged"]["judgement"]["margins"]["peak"]
        for x in (-margin, margin):
            ax.axvline(x, ls="--", color="k", lw=1)
        ax.axvline(0, color="0.7", lw=0.8)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small", loc="best")
    else:
        ax.text(0.5, 0.5, "no judged configuration", ha="center", transform=ax.transAxes)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels([f"{q} {s}" for q, s in names], fontsize=8)
    ax.invert_yaxis()
    ax.set(xlabel="coupled − full mean (% of the full mean), with its interval",
           title=f"{impact_title(impact)}: o equivalent, x not equivalent, + cannot judge; "
                 f"dashed: the margin")
    fig.tight_layout()
    save_figure(fig, path)


def qualifying(table):
    """[(impact, row)] of the configurations that meet the goal."""
    return [(i, r) for i in table["impacts"] for r in i["configs"] if r["goal"]["qualifies"]]


def doc(table, runs, outcomes, projected_s, sweep, images, command):
    """The study's page (markdown), written whole from the table: what qualifies (or none,
    with each zone's verdict), how it is measured, the runs, the map and the paper's Table 1
    row."""
    lines = ["# Where coupling pays", "",
             f"Written by `{command}` (sweep `{sweep}`) from `table.json`; every figure below "
             f"is in that table. {MEASURE}", ""]
    lines += _claim_lines(table) + _method_lines() + _run_lines(runs, outcomes, projected_s)
    lines += _map_lines(table, images)
    t1 = table.get("table1")
    lines += table1_lines(t1) if t1 else ["Paper scale: not run (`--sweep full` or "
                                          "`--paper-seeds`)."]
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
        lines += ["**Nowhere shown.** No zone is equivalent on every statistic and cheap "
                  "enough; per impact:", ""]
        for impact in table["impacts"]:
            for row in impact["configs"]:
                lines.append(f"- {impact_title(impact)}, {row['config']}: "
                             f"{outcome(row['goal'])}: {row['goal']['why']}")
    return lines + [""]


def _method_lines():
    return ["## How it is measured", "",
            "- Each impact's full ensemble and each coupled zone run on the same packing "
            "seeds; the quantities of interest do not depend on the zone, so one full "
            "ensemble judges every zone of its impact (`compare F C` gives the same "
            "judgement).",
            "- The per-step speed-up is timed, when the table says `timed`, on one window "
            "of each model built afresh from its run's description, one after the other, in "
            "CPU time (bench/study_timing.py: at small and medium scale 0.2 ms into the "
            "impact, at paper scale right after the build; a grown zone in its final zone); "
            "the runs' own wall times per step are kept beside it (`runs`): on a loaded "
            "machine they gave 0.46-2.57 for the same pair of models.",
            "- Post-run checks: the paper's two a-posteriori checks, made at the end of each "
            "run: the FE's peak stress over the run in the cells outside the bridging band "
            "against the concrete's strengths, and the damaged bridging spheres, as the run's "
            "`summary.json` warns.", ""]


def _run_lines(runs, outcomes, projected_s):
    lines = ["## The runs", "",
             f"Projected cost of the plan on one quiet core: {projected_s / 3600:.2f} h "
             f"(bench/results.json). Each run is a `slab` run in its folder of the study's.",
             "", "| run | seed | steps | status | wall s |", "|---|---|---|---|---|"]
    for r in runs:
        o = outcomes.get(r.folder)
        s = o.summary if o else None
        wall = None if s is None else spent(s)
        lines.append(f"| {r.config.folder} | {r.seed} | {r.spec().steps or 'default'} | "
                     f"{o.status if o else 'not run'} | {_f(wall, '{:.0f}')} |")
    return lines + [""]


def _map_lines(table, images):
    lines = ["## The map", ""]
    for impact in table["impacts"]:
        lines += [f"### {impact_title(impact)}", "", _full_line(impact), "",
                  HEADER.rstrip("\n")]
        lines += [config_line(row) for row in impact["configs"]]
        if impact["group"] in images:
            lines += ["", f"![{impact_title(impact)}]({images[impact['group']]})"]
        lines.append("")
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
    blocks = [heading("Where coupling pays"), paragraph(MEASURE),
              items(found) if found else paragraph("No zone is shown equivalent and cheap "
                                                   "enough.")]
    for impact in table["impacts"]:
        blocks += [heading(impact_title(impact)), paragraph(_full_line(impact)),
                   html_table(HEADER_CELLS, [[cell(c) for c in config_cells(row)]
                                             for row in impact["configs"]],
                              f"impact-{impact['group']}"),
                   picture(out / f"{impact['group']}.png",
                           f"{impact_title(impact)}: each zone's differences from the full "
                           f"mean, with their intervals, against the margin")]
    t = table.get("table1")
    if t:
        blocks += [heading(f"The paper's Table 1 row ({t['velocity']:g} m/s, {t['config']})"),
                   html_table(TABLE1_HEADER, _table1_rows(t), "table1")]
    return write_page(out / "report.html", "study: where coupling pays", blocks)
