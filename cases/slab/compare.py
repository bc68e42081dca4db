"""Coupled against full: sensor histories, damage, cost (`compare FULL COUPLED`)."""
import json

import numpy as np

from common.files import save_figure, write_json
from orchestrator.run.outputs import damage_map, read_sensors


def compare(full_dir, coupled_dir, out):
    """Coupled against full: sensor histories, damage, cost. Writes comparison.json + PNGs."""
    runs = {}
    for key, folder in (("full", full_dir), ("coupled", coupled_dir)):
        summary = json.loads((folder / "summary.json").read_text())
        if summary["model"] != key:
            raise ValueError(f"{folder} holds a {summary['model']!r} run, expected {key!r}")
        runs[key] = (summary, read_sensors(folder / "sensors.csv"), np.load(folder / "damage.npz"))
    (sf, (tf, names, hf), df), (sc, (tc, names_c, hc), dc) = runs["full"], runs["coupled"]
    if names != names_c:
        raise ValueError(f"sensor names differ: {names} vs {names_c}")
    if sf["spec"]["radius"] != sc["spec"]["radius"]:
        raise ValueError("the two runs have different sphere radii: not the same slab")
    t_end = min(tf[-1], tc[-1])
    t = tf[tf <= t_end]
    sensors = {}
    for i, name in enumerate(names):
        full_z = hf[tf <= t_end, i, 2]
        coupled_z = np.interp(t, tc, hc[:, i, 2])
        peak_f, peak_c = np.abs(full_z).max(), np.abs(coupled_z).max()
        sensors[name] = {
            "peak_full": peak_f, "peak_coupled": peak_c,
            "peak_time_full_s": t[np.argmax(np.abs(full_z))],
            "peak_time_coupled_s": t[np.argmax(np.abs(coupled_z))],
            "peak_ratio": peak_c / peak_f if peak_f > 0 else None,
            "nrms": float(np.sqrt(np.mean((coupled_z - full_z) ** 2)) / peak_f) if peak_f > 0 else None,
        }
    # damage maps: the coupled slab spheres are a subset of the full ones (same packing)
    where = {int(k): j for j, k in enumerate(df["slab_index"])}
    match = np.array([where[int(k)] for k in dc["slab_index"]])
    in_zone = dc["in_de_zone"]
    d_full, d_coupled = df["damage"][-1][match], dc["damage"][-1]
    vol_c = 4.0 / 3.0 * np.pi * dc["radius"] ** 3
    damage = {
        "broken_links_full": sf["damage"]["broken_links"],
        "broken_links_coupled": sc["damage"]["broken_links"],
        "damaged_volume_full_m3": sf["damage"]["damaged_volume_m3"],
        "damaged_volume_coupled_m3": sc["damage"]["damaged_volume_m3"],
        "damage_map_correlation_de_zone": _correlation(d_full[in_zone], d_coupled[in_zone]),
        "damaged_volume_de_zone_full_m3": float(d_full[in_zone] @ vol_c[in_zone]),
        "damaged_volume_de_zone_coupled_m3": float(d_coupled[in_zone] @ vol_c[in_zone]),
    }
    v_f, v_c = damage["damaged_volume_full_m3"], damage["damaged_volume_coupled_m3"]
    damage["damaged_volume_ratio"] = v_c / v_f if v_f > 0 else None
    speedup = sf["s_per_step"] / sc["s_per_step"]
    result = {
        "full": str(full_dir), "coupled": str(coupled_dir), "compared_until_s": t_end,
        "full_elastic_outside": sf["spec"].get("elastic_outside", False),
        "sensors": sensors, "damage": damage,
        "speedup_per_step": speedup,
        "sphere_count_ratio": sf["n_spheres"] / sc["n_spheres"],
        "projected_100k_steps_s": {"full": 1e5 * sf["s_per_step"], "coupled": 1e5 * sc["s_per_step"]},
        "goals": {
            "peaks_within_10_percent": all(s["peak_ratio"] is not None and abs(s["peak_ratio"] - 1) <= 0.10
                                           for s in sensors.values()),
            "history_nrms_at_most_15_percent": all(s["nrms"] is not None and s["nrms"] <= 0.15
                                                   for s in sensors.values()),
            "damaged_volume_within_15_percent": damage["damaged_volume_ratio"] is not None
                                                and abs(damage["damaged_volume_ratio"] - 1) <= 0.15,
        },
    }
    write_json(out / "comparison.json", result)
    _plot_comparison(out, names, (tf, hf), (tc, hc), dc["positions"], d_full, d_coupled, in_zone)
    return result


def _correlation(a, b):
    if a.size < 2 or a.std() == 0 or b.std() == 0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def _plot_comparison(out, names, full, coupled, positions, d_full, d_coupled, in_zone):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for ax, i, name in zip(axes.ravel(), range(len(names)), names):
        for label, (t, h), style in (("full", full, "-"), ("coupled", coupled, "--")):
            ax.plot(t * 1e3, h[:, i, 2] * 1e3, style, label=label)
        ax.set(title=name, xlabel="time (ms)", ylabel="z displacement (mm)")
        ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "histories.png")
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    damage_map(axes[0], positions[in_zone], d_full[in_zone], "full: damage in the DE zone")
    damage_map(axes[1], positions[in_zone], d_coupled[in_zone], "coupled: damage in the DE zone")
    fig.tight_layout()
    save_figure(fig, out / "damage_maps.png")
