"""`compare`: coupled slab runs against full-YADE runs of the same slab: one of each, or
ensembles over packing seeds (folders made by `slab --seeds`, or several run folders)."""
from cli.commands._options import add_out, ranged

NAME = "compare"
HELP = ("compare FULL COUPLED: sensor histories, damage maps, speed-up; FULL and COUPLED may be "
        "ensembles (slab --seeds folders, or --full/--coupled with several runs)")


def configure(p):
    p.add_argument("full_dir", nargs="?", help="full run folder, or an ensemble folder")
    p.add_argument("coupled_dir", nargs="?", help="coupled run folder, or an ensemble folder")
    p.add_argument("--full", nargs="+", default=[], metavar="DIR", help="more full runs")
    p.add_argument("--coupled", nargs="+", default=[], metavar="DIR", help="more coupled runs")
    p.add_argument("--verdict", action="store_true",
                   help="judge the coupled runs on the quantities of interest (needs 2 same-seed "
                        "pairs or 2 runs of each model; given anyway when they are there)")
    p.add_argument("--margin", type=ranged(0, 1), default=None, metavar="FRACTION",
                   help="the equivalence margin of every judged statistic, a fraction of the "
                        "full mean (default: 0.10 on peaks, their times and histories)")
    add_out(p, "folder for comparison.json and plots")


def run(args):
    from cases.slab.compare import compare, load
    from cases.slab.compare_page import verdict_text
    from cases.slab.judge import margins
    from orchestrator.run.folder import check_out, prepare_out
    full = [d for d in [args.full_dir] if d] + args.full
    coupled = [d for d in [args.coupled_dir] if d] + args.coupled
    if not full:
        raise ValueError("give the full run(s): FULL_DIR or --full DIR ...")
    margins(args.margin)
    check_out(args.out, args.force, inputs=[*full, *coupled])
    runs = load(full, coupled, verdict=args.verdict)   # every refusal before the folder is made
    out = prepare_out(args.out, args.force, inputs=[*full, *coupled])
    r = compare(*runs, out, verdict=args.verdict, margin=args.margin)
    for seed, p in r["pairs"].items():
        for name, s in p["sensors"].items():
            print(f"seed {seed} {name:14s} peak ratio {_f(s['peak_ratio'])}  nRMS "
                  f"{_f(s['nrms'])}  peak at {s['peak_time_full_s'] * 1e3:.2f} ms (full), "
                  f"{s['peak_time_coupled_s'] * 1e3:.2f} ms (coupled)")
        print(f"seed {seed} damaged volume ratio {_f(p['damage']['damaged_volume_ratio'])}, "
              f"speed-up per step {p['speedup_per_step']:.2f} (sphere ratio "
              f"{p['sphere_count_ratio']:.2f})"
              + ("" if p["goals"] is None else f"; goals {p['goals']}"))
    if "within_full_scatter" in r.get("ensemble", {}):
        for name, v in r["ensemble"]["within_full_scatter"]["sensors"].items():
            n = v["nrms"]
            print(f"{name:14s} coupled nRMS to the full mean {_f(n['coupled_max'])} (largest), "
                  f"full scatter {_f(n['full_leave_one_out_max'])}: "
                  f"{verdict_text(n)}")
        for name, v in r["ensemble"]["within_full_scatter"].get("damage", {}).items():
            print(f"{name:14s} coupled |ratio - 1| to the full mean {_f(v['coupled_max'])} "
                  f"(largest), full scatter {_f(v['full_leave_one_out_max'])}: "
                  f"{verdict_text(v)}")
        print(_scatter_line(r))
    if "judgement" in r:
        for side, ends in r["judgement"]["event_end_s"].items():
            print(f"event ends, {side}: " + "; ".join(
                f"seed {s} impactor {_ms(e['impactor_s'])}, slab {_ms(e['slab_s'])}"
                for s, e in ends.items()))
    if r.get("energy_split"):
        print(_energy_line(r["energy_split"]))
    for line in r["warnings"]:
        print(f"WARNING: {line}")
    if "judgement" in r:
        from cases.slab.judge import bias_line
        line = bias_line(r["judgement"])
        if line:
            print(line)
    if "headline" in r:
        print(r["headline"])
    print(f"results in {out}; the page: {out / 'report.html'}")
    return 0


def _energy_line(split):
    """One line: each energy term's share of the input at the window's end, full / compared
    (the members' means, every place summed)."""
    from cases.slab.energies import TERMS

    def share(side, j):
        return f"{100 * j / side['input_J']:.1f}"
    f, c = split["full"], split["coupled"]
    terms = [f"{t} {share(f, sum(f['terms'][t].values()))}/{share(c, sum(c['terms'][t].values()))}"
             for t in TERMS]
    return (f"energy at the end, % of the impact's, full/coupled: {', '.join(terms)}, "
            f"residual {share(f, f['residual_J'])}/{share(c, c['residual_J'])}")


def _scatter_line(r):
    """The single-sphere sensors and the damage figures against the full scatter in one
    line, naming every figure outside it (nRMS and peak alike); with the per-step speed-up of
    the same-seed pairs. The verdict is the yardstick's headline, printed last."""
    w = r["ensemble"]["within_full_scatter"]
    verdicts = {**{f"{k} {s}": v[s] for k, v in w["sensors"].items() for s in ("nrms", "peak")},
                **w.get("damage", {})}
    outside = [k for k, v in verdicts.items() if not v["within"]]
    speed = [p["speedup_per_step"] for p in r["pairs"].values()]
    cost = (f"; speed-up per step {min(speed):.2f}-{max(speed):.2f} (the runs' own wall "
            f"times)" if speed else "")
    where = (f"OUTSIDE on {', '.join(outside)}" if outside
             else f"within on all {len(verdicts)} figures")
    return f"sensors (one sphere each) and damage against the full scatter: {where}{cost}"


def _f(x):
    return "n/a" if x is None else f"{x:.3f}"


def _ms(t):
    return "not within the window" if t is None else f"{1e3 * t:.2f} ms"
