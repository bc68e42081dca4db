"""Figures of an ensemble comparison: the full ensemble's band with the coupled members over it,
and the mean damage maps."""
import numpy as np

from orchestrator.ensemble import band, resample
from common.files import save_figure
from orchestrator.run.outputs import damage_map


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_histories(path, full, coupled, sensors, ylabel="z displacement (mm)", scale=1e3,
                   labels=("full", "coupled")):
    """One panel per sensor: the full ensemble's min–max band and mean, each coupled member as a
    line. full, coupled: {seed: (t (s), h (n_times, n_sensors))}, all on the common time base of
    orchestrator.ensemble; histories are multiplied by `scale` (default: m to mm); `labels`:
    the names of the two sides in the legends."""
    plt = _pyplot()
    t, mean, lo, hi = band(full, coupled)
    cols = 2 if len(sensors) > 1 else 1
    rows = -(-len(sensors) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 3.5 * rows), sharex=True,
                             squeeze=False)
    for k, (ax, name) in enumerate(zip(axes.ravel(), sensors)):
        ax.fill_between(t * 1e3, lo[:, k] * scale, hi[:, k] * scale, color="0.8",
                        label=f"{labels[0]}, {len(full)} seeds: min–max")
        ax.plot(t * 1e3, mean[:, k] * scale, "k-", lw=1.5, label=f"{labels[0]}: mean")
        for seed in sorted(coupled):
            ax.plot(t * 1e3, resample(t, coupled[seed])[:, k] * scale, "--", lw=1,
                    label=f"{labels[1]}, seed {seed}")
        ax.set(title=name, xlabel="time (ms)", ylabel=ylabel)
        ax.legend(fontsize="small")
    for ax in axes.ravel()[len(sensors):]:
        ax.set_visible(False)
    fig.tight_layout()
    save_figure(fig, path)


def plot_mean_damage_maps(path, maps, n_full, n_coupled, labels=("full", "coupled")):
    """Plan views of the ensembles' mean damage maps (orchestrator.ensemble.mean_damage_maps),
    one dot per grid cell that holds spheres; `labels` as plot_histories'."""
    plt = _pyplot()
    x, y = np.meshgrid(maps["x"], maps["y"], indexing="ij")
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, key, label, n in zip(axes, ("full", "coupled"), labels, (n_full, n_coupled)):
        grid = maps[key]
        held = np.isfinite(grid)
        damage_map(ax, np.column_stack([x[held], y[held]]), grid[held],
                   f"{label}: mean damage of {n} seeds")
    corr = maps["correlation"]
    fig.suptitle("correlation of the mean maps: " + ("undefined" if corr is None
                                                     else f"{corr:.3f}"))
    fig.tight_layout()
    save_figure(fig, path)


def plot_plan_maps(path, x, y, maps, unit, title):
    """Plan views side by side of grids {label: (n_x, n_y)} on the cell centres x, y, on one
    colour scale."""
    plt = _pyplot()
    top = max(float(np.nanmax(g)) for g in maps.values()) or 1.0
    fig, axes = plt.subplots(1, len(maps), figsize=(6 * len(maps), 5))
    for ax, (label, grid) in zip(np.atleast_1d(axes), maps.items()):
        image = ax.pcolormesh(x, y, grid.T, cmap="inferno_r", vmin=0, vmax=top, shading="nearest")
        ax.set(xlabel="x (m)", ylabel="y (m)", title=label, aspect="equal")
        fig.colorbar(image, ax=ax, shrink=0.8, label=unit)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
