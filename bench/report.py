"""Derived figures, goals and the Markdown table of a bench run (from the workers' raw output)."""
GB = 1e9  # SI gigabyte (stricter than GiB)
PAPER_STEPS = 100_000
GOALS = {"coupling_fraction": 0.10, "fe_fraction": 0.05, "speedup_over_ratio": 0.9,
         "full_memory_GB": 2.5, "coupled_memory_GB": 1.0, "coupled_100k_steps_h": 1.5,
         "fe_damage_fraction": 0.10, "paper_speedup": 10.0, "band_share": 0.40,
         "conversion_steps": 10.0}
# the conversions timed (bench.run): the default start zone's ring at each scale, and at
# paper scale a larger zone's
CONVERSIONS = ("conversion", "conversion_large")
MODEL_NAMES = {"full": "full", "coupled": "coupled", "coupled_damage": "coupled, FE damage"}


def model_figures(r):
    split = dict(r["timing"]["split_median_s"])
    split["output"] = r.get("output", {}).get("per_step_s", 0.0)
    step = r["timing"]["median_s"] + split["output"]
    impact = r["timing_impact"]["median_s"] + split["output"] if "timing_impact" in r else None
    return {"n_spheres": r["n_spheres"], "n_bridging_spheres": r["n_bridging_spheres"],
            "step_s": step, "split_s": split, "build_s": r["build_s"],
            "impact_step_s": impact, "dt": r.get("dt"),
            "peak_GB": r["peak_rss_bytes"] / GB,
            "projected_100k_steps_s": PAPER_STEPS * step,
            "projected_100k_steps_impact_s": None if impact is None else PAPER_STEPS * impact,
            "s_per_simulated_ms": {w: None if x is None or not r.get("dt") else x * 1e-3 / r["dt"]
                                   for w, x in (("before_contact", step), ("impact", impact))},
            "projected_100k_steps_with_build_s": PAPER_STEPS * step + r["build_s"]}


def derive(raw):
    per_scale = {}
    for scale, runs in raw["scales"].items():
        full, coupled = model_figures(runs["full"]), model_figures(runs["coupled"])
        c = runs["coupled"]
        ratio = full["n_spheres"] / coupled["n_spheres"]
        speedup = full["step_s"] / coupled["step_s"]
        wall_speedup = runs["full"]["timing"]["wall_median_s"] / c["timing"]["wall_median_s"]
        nb = coupled["n_bridging_spheres"]
        variants = c["variants"]
        per_scale[scale] = {
            "full": full, "coupled": coupled,
            "sphere_count_ratio": ratio, "speedup_per_step": speedup,
            "speedup_per_step_impact": (full["impact_step_s"] / coupled["impact_step_s"]
                                        if coupled["impact_step_s"] else None),
            "speedup_over_ratio": speedup / ratio,
            "wall_time_speedup_per_step": wall_speedup,
            "coupling_fraction": coupled["split_s"]["coupling"] / coupled["step_s"],
            "fe_fraction": coupled["split_s"]["fe"] / coupled["step_s"],
            "coupling_per_bridging_sphere_s": {v: x["coupling_s"] / nb for v, x in variants.items()},
            "full_factorisation_s": variants.get("full", {}).get("factorisation_s"),
            "full_system_size": variants.get("full", {}).get("system_size"),
            "guarded_rotation_rows": variants.get("diagonal", {}).get("guarded_rows"),
            "coupling_parts_s": c["coupling_parts"],
        }
        if "coupled_damage" in runs:      # the coupled model with the FE that cracks
            d = runs["coupled_damage"]
            window = d.get("timing_impact", d["timing"])
            per_scale[scale]["coupled_damage"] = model_figures(d)
            per_scale[scale]["fe_damage_fraction"] = (window["split_median_s"]["fe"] /
                                                      window["median_s"])
        for key in CONVERSIONS:          # one conversion of the zone grown during the run
            if key in runs:
                v = runs[key]
                per_scale[scale][key] = {k: v[k] for k in (
                    "spheres_before", "spheres_after", "conversion_s", "build_wall_s",
                    "carry_wall_s", "wall_s", "grown_step_s", "conversion_steps",
                    "start_zone_m")}
    threads = raw["threads"]
    one = threads.get("1", {}).get("s_per_step")
    thread_speedup = {t: one / x["s_per_step"] for t, x in threads.items()} if one else {}
    return {"per_scale": per_scale, "thread_speedup": thread_speedup,
            "goals": goals(per_scale)}


def goals(per_scale):
    """Goals at paper scale; when paper was not measured (--quick), at the largest scale
    measured, labelled so."""
    scale = "paper" if "paper" in per_scale else list(per_scale)[-1]
    s = per_scale[scale]
    at = f" (at {scale} scale)"
    out = [
        _goal(f"coupling < {GOALS['coupling_fraction']:.0%} of the coupled step" + at,
              s["coupling_fraction"] < GOALS["coupling_fraction"], f"{s['coupling_fraction']:.1%}"),
        _goal(f"FE < {GOALS['fe_fraction']:.0%} of the coupled step" + at,
              s["fe_fraction"] < GOALS["fe_fraction"], f"{s['fe_fraction']:.1%}"),
        _goal(f"speed-up >= {GOALS['speedup_over_ratio']} x sphere-count ratio" + at,
              s["speedup_over_ratio"] >= GOALS["speedup_over_ratio"],
              f"{s['speedup_per_step']:.2f}x for {s['sphere_count_ratio']:.2f}x fewer spheres "
              f"= {s['speedup_over_ratio']:.2f} x the ratio"),
    ]
    h = s["coupled"]["projected_100k_steps_impact_s"] or s["coupled"]["projected_100k_steps_s"]
    out.append(_goal(f"coupled 100,000 steps <= {GOALS['coupled_100k_steps_h']:g} h on one core "
                     f"(impact window)" + at, h / 3600 <= GOALS["coupled_100k_steps_h"],
                     f"{h / 3600:.2f} h"))
    name = f"paper-scale coupled model >= {GOALS['paper_speedup']:g}x per step (impact window)"
    x = s["speedup_per_step_impact"] or s["speedup_per_step"]
    if scale == "paper":
        out.append(_goal(name, x >= GOALS["paper_speedup"],
                         f"{x:.2f}x ({s['speedup_per_step']:.2f}x before contact) for "
                         f"{s['sphere_count_ratio']:.2f}x fewer spheres"))
    else:
        out.append(_goal(name, None, f"not measured ({scale}: {x:.2f}x)"))
    if "fe_damage_fraction" in s:
        out.append(_goal(f"FE with damage < {GOALS['fe_damage_fraction']:.0%} of the coupled "
                         f"step (impact window)" + at,
                         s["fe_damage_fraction"] < GOALS["fe_damage_fraction"],
                         f"{s['fe_damage_fraction']:.1%}"))
    for model, key in (("full", "full_memory_GB"), ("coupled", "coupled_memory_GB")):
        name = f"paper-scale {model} model < {GOALS[key]:g} GB"
        if scale == "paper":
            out.append(_goal(name, s[model]["peak_GB"] < GOALS[key], f"{s[model]['peak_GB']:.2f} GB"))
        else:
            out.append(_goal(name, None, f"not measured ({scale}: {s[model]['peak_GB']:.2f} GB)"))
    timed = [s[key] for key in CONVERSIONS if key in s]
    if timed:
        out.append(_goal(f"a conversion of the grown zone <= {GOALS['conversion_steps']:g} steps "
                         f"of the grown model" + at,
                         max(v["conversion_steps"] for v in timed) <= GOALS["conversion_steps"],
                         "; ".join(f"{v['conversion_steps']:.0f} steps ({v['conversion_s']:.2f} s, "
                                   f"{v['spheres_before']:,} to {v['spheres_after']:,} spheres)"
                                   for v in timed)))
    c = s["coupled"]
    share = c["n_bridging_spheres"] / c["n_spheres"]
    out.append(_goal(f"bridging share of the default coupled model's spheres <= "
                     f"{GOALS['band_share']:.0%}" + at, share <= GOALS["band_share"],
                     f"{share:.1%}"))
    return out


def _goal(goal, met, figure):
    return {"goal": goal, "met": met, "figure": figure}


def _ms(x):
    return f"{1e3 * x:.2f}"


def _opt_ms(x):
    return "-" if x is None else _ms(x)


def _opt(x, unit):
    return "-" if x is None else f"{x / unit:.2f}"


def markdown(results):
    lines = _header(results)
    for section in (_time_table, _speedup_table, _coupling_cost_table, _coupling_parts_table,
                    _conversion_table):
        lines += section(results["per_scale"])
    lines += _threads_table(results) + ["", NOTES]
    return "\n".join(lines) + "\n"


def _header(results):
    m = results["machine_at_start"]
    lines = [
        "# Benchmarks", "",
        f"Generated by `make bench` (`/usr/bin/python3 -m bench{' --quick' if results['mode'] == 'quick' else ''}`) "
        f"on {results['date_utc']}, {m['cpus']} CPUs, load average at start "
        f"{m['load_average'][0]:.2f}, at end {results['machine_at_end']['load_average'][0]:.2f}; "
        f"{results['bench_wall_s'] / 60:.1f} min. All figures come from this one run "
        "(bench/results.json): compare ratios, not absolute times across runs.", "",
        "Each model runs in its own process with 1 OpenMP thread (except the threads table); "
        "times are medians of the timed steps after warm-up, in the process's CPU time, which "
        "equals wall time on a quiet machine and, unlike it, hardly changes when other jobs "
        "share the cores (the wall-time speed-up is shown alongside: where they differ, the "
        "machine was loaded). Output = the run loop's sensors, energy check and ParaView "
        "frames, amortised over their periods. Two windows are timed: right after the build "
        "(impactor not yet in contact), and 0.5 ms into the run, while the slab cracks under "
        "the impactor (contacts, damage, link deletion).", "",
        "## Goals", "", "| goal | figure | status |", "|---|---|---|",
    ]
    for g in results["goals"]:
        status = {True: "met", False: "**missed**", None: "n/a"}[g["met"]]
        lines.append(f"| {g['goal']} | {g['figure']} | {status} |")
    return lines


def _time_table(per_scale):
    lines = ["", "## Time per step (ms) and memory", "",
              "| scale | model | spheres | bridging | YADE | FE | coupling | output | step | "
              "step in the impact | build (s) | peak (GB) | 100,000 steps (h), before contact "
              "/ impact | s per simulated ms, impact |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for scale, s in per_scale.items():
        for model in MODEL_NAMES:
            if model not in s:
                continue
            f = s[model]
            sp = f["split_s"]
            lines.append(f"| {scale} | {MODEL_NAMES[model]} | {f['n_spheres']:,} | {f['n_bridging_spheres']:,} | "
                         f"{_ms(sp['yade'])} | {_ms(sp.get('fe', 0))} | {_ms(sp.get('coupling', 0))} | "
                         f"{_ms(sp['output'])} | {_ms(f['step_s'])} | {_opt_ms(f['impact_step_s'])} | "
                         f"{f['build_s']:.1f} | {f['peak_GB']:.2f} | "
                         f"{f['projected_100k_steps_s'] / 3600:.2f} / "
                         f"{_opt(f['projected_100k_steps_impact_s'], 3600)} | "
                         f"{_opt(f['s_per_simulated_ms']['impact'], 1)} |")
    return lines


def _speedup_table(per_scale):
    lines = ["", "## Speed-up", "",
              "| scale | sphere-count ratio | speed-up per step | speed-up / ratio | "
              "speed-up in the impact | coupling share | FE share | bridging share of coupled "
              "spheres | speed-up in wall time (steps only) |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for scale, s in per_scale.items():
        c = s["coupled"]
        impact = s["speedup_per_step_impact"]
        lines.append(f"| {scale} | {s['sphere_count_ratio']:.2f} | {s['speedup_per_step']:.2f} | "
                     f"{s['speedup_over_ratio']:.2f} | {'-' if impact is None else f'{impact:.2f}'} | "
                     f"{s['coupling_fraction']:.1%} | "
                     f"{s['fe_fraction']:.1%} | {c['n_bridging_spheres'] / c['n_spheres']:.0%} | "
                     f"{s['wall_time_speedup_per_step']:.2f} |")
    return lines


def _coupling_cost_table(per_scale):
    lines = ["", "## Coupling cost per bridging sphere per step", "",
              "Full Lagrange (Woodbury, the coupled FE mass matrix factorised once) against "
              "diagonalised (row sums), timed on the same model in the same process.", "",
              "| scale | bridging spheres | diagonalised (µs) | full (µs) | full: factorisation (s) "
              "| full: system size | guarded rotation rows |", "|---|---:|---:|---:|---:|---:|---:|"]
    for scale, s in per_scale.items():
        per = s["coupling_per_bridging_sphere_s"]
        fact = s["full_factorisation_s"]
        lines.append(f"| {scale} | {s['coupled']['n_bridging_spheres']:,} | "
                     f"{1e6 * per.get('diagonal', float('nan')):.3f} | "
                     f"{1e6 * per.get('full', float('nan')):.3f} | "
                     f"{'-' if fact is None else f'{fact:.3f}'} | {s['full_system_size'] or '-'} | "
                     f"{s['guarded_rotation_rows']} |")
    return lines


def _coupling_parts_table(per_scale):
    lines = ["", "## Where the coupling time goes (ms, each piece timed alone, diagonalised)", "",
              "| scale | read spheres | multipliers | correct + write spheres | write alone | "
              "correct FE | exchange meter | direct memory exchange | YADE API read + write |",
              "|---|---:|---:|---:|---:|---:|---:|---|---:|"]
    for scale, s in per_scale.items():
        p = s["coupling_parts_s"]
        lines.append(f"| {scale} | {_ms(p['read_s'])} | {_ms(p['multipliers_s'])} | "
                     f"{_ms(p['correct_and_write_spheres_s'])} | {_ms(p['write_s'])} | "
                     f"{_ms(p['correct_fe_s'])} | {_ms(p['exchange_meter_s'])} | "
                     f"{'yes' if p['direct_memory_exchange'] else 'no (YADE API)'} | "
                     f"{_ms(p['api_read_s'])} + {_ms(p['api_write_s'])} |")
    return lines


def _conversion_table(per_scale):
    lines = ["", "## A conversion of the zone grown during the run", "",
              "The default grown zone (`slab --model coupled`, docs/auto-zone.md) converts the "
              "ring of FE cells around its start zone, a few steps into the run; its cost on "
              "the same clock as the steps, and in steps of the grown model. At paper scale "
              "also the ring around a 1.5 m start zone: a late conversion's size. Of it, wall "
              "time: build (the grown model's, through the builder, in the running scene), "
              "carry (the state into what is new).", "",
              "| scale | start zone (m) | spheres before | after | conversion (s) | build (s) | "
              "carry (s) | grown model's step (ms) | conversion in its steps |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for scale, s in per_scale.items():
        for v in (s[key] for key in CONVERSIONS if key in s):
            lines.append(f"| {scale} | {v['start_zone_m']:g} | {v['spheres_before']:,} | "
                         f"{v['spheres_after']:,} | "
                         f"{v['conversion_s']:.2f} | {v['build_wall_s']:.2f} | "
                         f"{v['carry_wall_s']:.2f} | "
                         f"{_ms(v['grown_step_s'])} | {v['conversion_steps']:.0f} |")
    return lines


def _threads_table(results):
    lines = ["", "## YADE with OpenMP threads (full model, wall time)", "",
              "| threads | scale | spheres | ms/step | speed-up |", "|---:|---|---:|---:|---:|"]
    for t, x in results["raw"]["threads"].items():
        lines.append(f"| {t} | {x['scale']} | {x['n_spheres']:,} | {_ms(x['s_per_step'])} | "
                     f"{results['thread_speedup'].get(t, float('nan')):.2f} |")
    return lines


NOTES = """## Notes

- The exchange with YADE reads and writes the bridging spheres' state by a numpy
  gather/scatter in YADE's memory (`yade_side/memory.py`): the field offsets are found
  through YADE's own bulk API and every body is checked bit for bit against it before use.
  YADE's `Subdomain.get/setStateValuesFromIds` (last column above, the fallback) converts
  every value through a Python float.
- The diagonalised multipliers never form S = Δt²(D⁻¹ + G W⁻¹ Gᵀ), which couples every pair of
  spheres sharing an element node (hundreds of MB already at small scale).
- What remains of the coupling is the multipliers (two sparse products with G per step) and
  the sphere corrections; both scale with the number of bridging spheres. The band's spheres
  are full CPM spheres for YADE, so the band bounds the speed-up too: every scale defaults
  to one layer of 3-diameter elements around a 0.5 m box (the zone the map of
  docs/where-coupling-pays.md finds equivalent to the full model at 10 m/s, and the one
  the grown zone starts from).
"""
