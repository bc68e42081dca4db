"""The slab variants' measurement (`python3 -m cli variants DIR ...`): for full runs,
how far the impact goes and how much of the damage lies outside the DE zone a coupled model of
the same slab would have, i.e. whether damage localizes enough for a coupled model to pay.

Per full run: the peak z displacement of the sphere under the impact (its sensor), the damaged
volume (Σ damage × sphere volume, damage = broken / initial links), the share of it outside the
run's DE zone (`in_de_zone` of damage.npz), and, of the links damaged beyond DAMAGED_OMEGA
(broken ones included), the share whose midpoint lies outside that zone (summary.json's
`links_outside_de_zone`, which the full run records at its end)."""
import numpy as np

from cases.slab.links import DAMAGED_OMEGA, share


def measure(run):
    """The figures of one full run (cases.slab.compare.Run)."""
    if run.model != "full":
        raise ValueError(f"{run.folder} holds a {run.model!r} slab run: the variants' measurement "
                         f"takes full runs (damage outside the DE zone exists only there)")
    if "under_impact" not in run.names:
        raise ValueError(f"{run.folder}: no under_impact sensor in sensors.csv ({run.names})")
    z = run.h[:, run.names.index("under_impact"), 2]
    peak = int(np.argmax(np.abs(z)))
    d = run.damage
    damaged = d["damage"][-1] * 4.0 / 3.0 * np.pi * d["radius"] ** 3
    outside = damaged[~d["in_de_zone"].astype(bool)].sum()
    links = run.summary.get("links_outside_de_zone")
    spec = run.spec
    return {
        "folder": str(run.folder), "variant": variant(spec), "scale": spec.get("scale"),
        "seed": run.seed, "de_zone_m": spec.get("de_zone"), "full_width": spec.get("full_width"),
        "end_time_s": float(run.t[-1]),
        "peak_under_impact_m": float(abs(z[peak])), "peak_time_s": float(run.t[peak]),
        "end_under_impact_m": float(z[-1]),
        "end_speed_under_impact_m_s": (float((z[-1] - z[-2]) / (run.t[-1] - run.t[-2]))
                                       if len(z) > 1 else None),
        "damaged_volume_m3": float(damaged.sum()),
        "damaged_volume_outside_m3": float(outside),
        "damaged_volume_share_outside": share(float(outside), float(damaged.sum())),
        "links_outside_de_zone": links,
        "damaged_links_share_outside": None if links is None else links["damaged_share_outside"],
    }


def variant(spec):
    """The variant's name: the concrete, '+ reinforced' when the run had bars."""
    name = spec["concrete"]
    return f"{name} + reinforced" if spec.get("reinforced") else name


def table(rows):
    """A Markdown table of measure()'s rows."""
    pct = lambda x: "n/a" if x is None else f"{100 * x:.1f} %"
    lines = ["| variant | scale | seed | peak under impact (mm) | at (ms) | end speed (m/s) | "
             "damaged volume (m³) | outside the DE zone: volume | links ω > "
             f"{DAMAGED_OMEGA:g} |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        speed = r["end_speed_under_impact_m_s"]
        links = r["links_outside_de_zone"]
        count = ("not recorded" if links is None else
                 f"{pct(links['damaged_share_outside'])} ({links['damaged']} of "
                 f"{links['damaged_total']})")
        lines.append(f"| {r['variant']} | {r['scale']} | {r['seed']} | "
                     f"{1e3 * r['peak_under_impact_m']:.1f} | {1e3 * r['peak_time_s']:.2f} | "
                     f"{'n/a' if speed is None else f'{speed:.2f}'} | "
                     f"{r['damaged_volume_m3']:.4g} | {pct(r['damaged_volume_share_outside'])} | "
                     f"{count} |")
    return "\n".join(lines)


def measure_folders(folders):
    """measure() of every full run in `folders` (run folders or `slab --seeds` ensembles),
    in the order given, seeds ascending within an ensemble."""
    from cases.slab.compare import members
    return [measure(run) for folder in folders
            for _, run in sorted(members([folder], "full").items())]
