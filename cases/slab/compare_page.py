"""report.html of a `compare`: the verdict table, where the impact energy went, the same-seed
pairs, the sensor bands and damage maps (the PNGs compare wrote, inlined) and each compared
run's own checks, in one page.
Every figure in its tables is comparison.json's, printed to 4 significant digits."""
from common.html import heading, items, paragraph, picture, table, write_page


def num(x):
    return "n/a" if x is None else float(f"{x:.4g}")


def pair_suffix(seed, pairs):
    """The file-name suffix of a same-seed pair's pictures (none when there is one pair)."""
    return f"-seed-{seed}" if pairs > 1 else ""


def verdict_text(v):
    """within / OUTSIDE, and what weakens it: two full runs only, or a scatter so wide (or a
    figure so null: no run damaged) that a null prediction lies within it too."""
    notes = [n for n, on in (("weak: 2 full runs", v["weak"]),
                             ("a null prediction is within too", v.get("null_within")))
             if on]
    return ("within" if v["within"] else "OUTSIDE") + (f" ({'; '.join(notes)})" if notes else "")


def verdict_cell(v):
    return verdict_text(v), "good" if v["within"] else "bad"


def _members(r):
    """The test and its members: pairs, or full + coupled runs."""
    n = r["n_pairs"] if r["test"] == "paired" else f"{r['n_full']} + {r['n_coupled']}"
    return f"{r['test']} ({n})"


def _yardstick(result, out):
    """The QoIs' verdicts (cases.slab.judge): its headline, a row per judged statistic."""
    j = result["judgement"]
    rows = []
    for name, stats in j["qoi"].items():
        for s, r in stats.items():
            verdict = (r["verdict"], "good" if r["verdict"] == "equivalent" else "bad")
            if "test" not in r:                 # not judged: the window's end
                rows.append([name, s, "", "", "", "", "",
                             (f"not judged (extreme at the window's end: "
                              f"{', '.join(r['last_sample'])})", "bad")])
                continue
            bound = (f"≤ {num(r['upper'])}" if s == "history"
                     else f"[{num(r['interval'][0])}, {num(r['interval'][1])}]")
            need = r.get("members_needed")
            if r["verdict"] == "cannot judge":
                verdict = (f"cannot judge (needs {'> 1000' if need is None else need} "
                           f"members)", "bad")
            rows.append([name, s, _members(r),
                         num(r["difference"]), bound, num(r["se"]), num(r["margin"]), verdict])
    return [heading("The yardstick: quantities of interest"),
            paragraph(result["headline"]),
            paragraph(f"Window {num(1e3 * j['window_s'][0])}-{num(1e3 * j['window_s'][1])} ms. "
                      f"Differences relative to the full mean (coupled - full); the verdict is "
                      f"'equivalent' when the 90 % interval of the mean difference lies within "
                      f"± the margin (the history's: its rms, and the bound of it), 'cannot "
                      f"judge' when the members' spread is too wide for the margin "
                      f"(docs/slab.md, 'How a comparison is judged')."),
            table(["QoI", "statistic", "test (members)", "difference", "90 % interval / bound",
                   "standard error", "margin", "verdict"], rows, "yardstick"),
            picture(out / "quantities.png", "the judged QoIs of every member: full solid, "
                                            "compared dashed, a colour per seed"),
            picture(out / "profiles.png", "the deflection along the span at the centre's "
                                          "peak, every member"),
            picture(out / "cracking_maps.png", "the energy dissipated by cracking per FE plan "
                                               "cell, mean of each ensemble")]


def _energy_split(split):
    """Where the impact energy went (cases.slab.energies), the members' means at the window's
    end: a row per term, full / compared per place, % of the input."""
    from cases.slab.energies import REGIONS, TERMS
    f, c = split["full"], split["coupled"]
    share = lambda side, j: 100 * j / side["input_J"]                    # noqa: E731
    rows = [[term] + [f"{num(share(f, f['terms'][term][r]))} / "
                      f"{num(share(c, c['terms'][term][r]))}" for r in REGIONS]
            for term in TERMS]
    rows.append(["residual", f"{num(share(f, f['residual_J']))} / "
                             f"{num(share(c, c['residual_J']))}"] + [""] * (len(REGIONS) - 1))
    return [heading("Where the energy went"),
            paragraph(f"% of the impact energy ({num(f['input_J'])} J full, "
                      f"{num(c['input_J'])} J compared), full / compared, the mean of "
                      f"{split['members']['full']} and {split['members']['coupled']} members at "
                      f"the window's end, by place: the compared model's DE zone, its band and "
                      f"what lies outside them, and the impactor (docs/slab.md, 'Where the "
                      f"energy goes'). The residual, the input less the terms, is what the measure "
                      f"misses."),
            table(["term", *REGIONS], rows, "energy-split")]


def write(result, full, coupled, out):
    """out/report.html for the comparison `result` of the runs {seed: Run} `full`, `coupled`."""
    blocks = [paragraph(f"Reference (full) runs: {', '.join(result['full'])}"),
              paragraph(f"Compared runs: {', '.join(result['coupled'])}")]
    if "judgement" in result:
        blocks += _yardstick(result, out)
    if result.get("energy_split"):
        blocks += _energy_split(result["energy_split"])
    ens = result.get("ensemble", {})
    if "within_full_scatter" in ens:
        w = ens["within_full_scatter"]
        rows = [[name, num(v["nrms"]["coupled_max"]), num(v["nrms"]["full_leave_one_out_max"]),
                 verdict_cell(v["nrms"]), num(v["peak"]["coupled_max"]),
                 num(v["peak"]["full_leave_one_out_max"]), verdict_cell(v["peak"])]
                for name, v in w["sensors"].items()]
        damage = [[name, num(v["coupled_max"]), num(v["full_leave_one_out_max"]),
                   verdict_cell(v)] for name, v in w.get("damage", {}).items()]
        blocks += [heading("Against the full model's own scatter"),
                   paragraph("Largest deviation of a compared run from the full mean against the "
                             "largest leave-one-out deviation of a full member (docs/slab.md)."),
                   table(["sensor", "nRMS, compared", "nRMS, full scatter", "verdict",
                          "peak |ratio − 1|, compared", "full scatter", "verdict"],
                         rows, "verdicts"),
                   table(["figure", "|ratio − 1|, compared", "full scatter", "verdict"], damage,
                         "damage-verdicts"),
                   picture(out / "ensemble_histories.png",
                           "z histories: the full members' band and the compared runs"),
                   picture(out / "ensemble_damage_maps.png", "mean damage maps, seen from above")]
    blocks.append(heading("Same-seed pairs"))
    rows = []
    for seed, p in result["pairs"].items():
        rows += [[seed, name, num(s["peak_ratio"]), num(s["nrms"]),
                  num(1e3 * s["peak_time_full_s"]), num(1e3 * s["peak_time_coupled_s"])]
                 for name, s in p["sensors"].items()]
    blocks.append(table(["seed", "sensor", "peak ratio", "nRMS", "peak at, full (ms)",
                         "peak at, compared (ms)"], rows, "pairs"))
    blocks.append(table(["seed", "damaged volume ratio", "damage map correlation (DE zone)",
                         "speed-up per step", "sphere-count ratio"],
                        [[seed, num(p["damage"]["damaged_volume_ratio"]),
                          num(p["damage"]["damage_map_correlation_de_zone"]),
                          num(p["speedup_per_step"]), num(p["sphere_count_ratio"])]
                         for seed, p in result["pairs"].items()], "pair-figures"))
    for seed in result["pairs"]:
        suffix = pair_suffix(seed, len(result["pairs"]))
        blocks += [picture(out / f"histories{suffix}.png", f"seed {seed}: z histories"),
                   picture(out / f"damage_maps{suffix}.png", f"seed {seed}: damage in the DE zone")]
    blocks.append(heading("The runs' own checks"))
    for label, runs in (("full", full), ("compared", coupled)):
        for seed, r in sorted(runs.items()):
            warnings = r.summary.get("warnings") or ["no warning"]
            blocks += [paragraph(f"{label} seed {seed} ({r.summary['model']}, {r.folder}):"),
                       items(warnings)]
    return write_page(out / "report.html", "compare: full against compared slab runs", blocks)
