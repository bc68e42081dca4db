"""The study of the paper's Figs. 4-7, and the check of the automatic r."""
import csv
from dataclasses import astuple

import numpy as np

from cases.wave1d.model import run, summarise
from cases.wave1d.plots import best, plot_study
from cases.wave1d.spec import Wave1DSpec


STUDY_LAYERS = (1, 2, 3, 4, 5, 6)
STUDY_RELAXATIONS = tuple(np.round(np.logspace(0, 2, 13), 3))   # 1 … 100, 6 per decade
AUTO_RATIOS = (2, 3, 4, 5, 6, 7, 8)
CSV_FIELDS = ("study", "variant", "solver", "relaxation", "layers", "ratio", "dt_safety",
              "weighting",
              "attenuation_percent", "low_frequency_transmission_change_percent",
              "incident_energy", "reflected_energy", "reflected_low_frequency_energy",
              "reflected_high_frequency_energy", "transmitted_low_frequency_energy",
              "transmitted_high_frequency_energy", "coupling_net_work", "seconds")


def study_cases(layers=STUDY_LAYERS, relaxations=STUDY_RELAXATIONS, ratios=AUTO_RATIOS,
                ratio=5, **options):
    """(study, variant, spec) of the sweep: the four variants at `ratio` over n_b and r, and
    the automatic r (both solvers) at n_b = 3 for every ratio. `options`: other Wave1DSpec
    fields (dt_safety, weighting)."""
    for nb in layers:
        for solver in ("full", "diagonal"):
            yield "variants", solver, Wave1DSpec(solver, 1.0, nb, ratio, **options)
            for r in relaxations:
                if r > 1:
                    yield "variants", f"{solver}+relaxation", Wave1DSpec(solver, r, nb, ratio,
                                                                          **options)
    for q in ratios:
        for solver in ("full", "diagonal"):
            yield "auto", f"{solver}+relaxation", Wave1DSpec(solver, "auto", 3, q, **options)


def run_study(out, cases, quiet=False):
    """Run `cases` (from study_cases), one reference per geometry; write study.csv, the
    figures and table.md into `out`. Returns the rows."""
    from orchestrator.run.progress import progress
    from common.files import write_text
    cases = list(cases)
    references, rows, shapes = {}, [], {}
    with progress(len(cases), "wave1d-study", quiet) as bar:
        for study, variant, spec in cases:
            ref_spec = spec.reference()
            key = astuple(ref_spec)
            if key not in references:
                references[key] = run(ref_spec)
            ref = references[key]
            res = ref if spec == ref_spec else run(spec)
            s = summarise(spec, res, ref)
            rows.append({"study": study, "variant": variant, "solver": spec.variant,
                         "relaxation": spec.relaxation, "layers": spec.layers,
                         "ratio": spec.ratio, "dt_safety": spec.dt_safety,
                         "weighting": spec.weighting,
                         **{k: s[k] for k in CSV_FIELDS if k in s}})
            if spec.layers == 3 and spec.ratio == 5:
                shapes[(variant, spec.relaxation)] = res
                shapes[("full", 1.0)] = ref
            bar.update()
    text = _csv_text(rows)
    write_text(out / "study.csv", text)
    write_text(out / "table.md", markdown_table(rows))
    plot_study(out, rows, shapes)
    return rows


def _csv_text(rows):
    import io
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    return buf.getvalue()


def markdown_table(rows):
    """The docs' tables: per n_b, diagonal alone and the best r of each relaxed variant
    (ratio 5), the 25–35 band of the paper; then the automatic r over the ratios."""
    lines = ["| n_b | diagonal r=1: att. % (LF %) | full+relax: best r, att. % (LF %) | "
             "diag+relax: best r, att. % (LF %) | diag+relax r in 25-35: att. % (LF %) | "
             "diag+relax: r with >= 80 % | r with >= 99 % |",
             "|---|---|---|---|---|---|---|"]
    for nb in sorted({r["layers"] for r in rows if r["study"] == "variants"}):
        diag = [r for r in rows if r["study"] == "variants" and r["variant"] == "diagonal"
                and r["layers"] == nb]
        cells = [f"{nb}", _fmt(diag[0]) if diag else "-"]
        for v in ("full+relaxation", "diagonal+relaxation"):
            b = best(rows, v, nb)
            cells.append(f"{b['relaxation']:g}: {_fmt(b)}" if b else "-")
        band = [r for r in rows if r["study"] == "variants" and r["variant"] ==
                "diagonal+relaxation" and r["layers"] == nb and 25 <= r["relaxation"] <= 35]
        cells.append(", ".join(f"r={r['relaxation']:g}: {_fmt(r)}" for r in band) or "-")
        relaxed = [r for r in rows if r["study"] == "variants" and r["layers"] == nb
                   and r["variant"] in ("diagonal", "diagonal+relaxation")]
        for level in (80, 99):
            ok = sorted(r["relaxation"] for r in relaxed if r["attenuation_percent"] >= level)
            cells.append(f"{ok[0]:g} – {ok[-1]:g} ({len(ok)} of {len(relaxed)})" if ok else "none")
        lines.append("| " + " | ".join(cells) + " |")
    auto = [r for r in rows if r["study"] == "auto"]
    if auto:
        lines += ["", "| ratio | auto r | variant | attenuation % | LF transmission change % |",
                  "|---|---|---|---|---|"]
        lines += [f"| {r['ratio']} | {r['relaxation']:g} | {r['variant']} | "
                  f"{r['attenuation_percent']:.2f} | "
                  f"{r['low_frequency_transmission_change_percent']:+.3f} |" for r in auto]
    return "\n".join(lines) + "\n"


def _fmt(row):
    return (f"{row['attenuation_percent']:.1f} "
            f"({row['low_frequency_transmission_change_percent']:+.2f})")
