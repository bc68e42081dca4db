"""What a run writes at its end: summary.json, sensors.csv, damage.npz and the plots; and how
they are read back."""
import numpy as np

from common.files import save_figure, save_npz, write_csv, write_json
from orchestrator.run.checks import fe_cells_checked
from yade_side import yade_threads


def summary(model, rec, schedule, wall, seconds, warnings, info, quantities=None):
    """summary.json's content: `info` first, then the run's figures; `quantities`: the
    run's QoIs (Model.quantities), whose definitions and end figures it records."""
    m, history, final = model, np.array(rec.history), rec.maps[-1]
    damaged = m.damaged_volume(final)
    stepper = m.stepper
    out = dict(info or {})
    out.update({
        "n_spheres": m.sphere_count(),
        "n_fe_nodes": 0 if m.fe is None else len(m.fe.nodes),
        "n_bridging_spheres": len(m.bridge_index),
        "steps": schedule.steps, "dt": m.dt, "critical_dt": m.critical,
        "wall_s": wall, "s_per_step": wall / schedule.steps,
        "yade_threads": yade_threads(), "bit_identical": yade_threads() == 1,
        "time_split_s": seconds,
        "sensors": {name: {"position": np.asarray(m.sensor_positions[i]).tolist(),
                           "peak_displacement": float(np.linalg.norm(history[:, i], axis=1).max()),
                           "peak_displacement_z": float(np.abs(history[:, i, 2]).max())}
                    for i, name in enumerate(m.sensor_names)},
        "damage": {"initial_links": int(m.damage.initial.sum()),
                   "broken_links": int(np.round(final @ m.damage.initial)),
                   "damaged_volume_m3": damaged["total"],
                   "damaged_volume_de_m3": damaged["de"], "damaged_volume_fe_m3": damaged["fe"],
                   "max_bridging_damage": float(final[m.bridge_index].max(initial=0.0))},
        "energy": rec.energy,
        "constraint_gap": rec.gaps,
        "coupling_energy_J": None if stepper is None else {
            "to_fe": stepper.exchange.to_fe, "net": stepper.exchange.net},
        "coupling": None if stepper is None else coupling_figures(stepper.coupling),
        "fe_peak_stress": None if m.fe is None else fe_peak(rec),
        "fe_damage": fe_damage(m) if m.fe_damages else None,
        "quantities": None if quantities is None else {
            **quantities.definitions(),
            **quantities.end_figures(np.array(rec.times), np.array(rec.quantities))},
        "warnings": warnings,
    })
    return out


def fe_peak(rec):
    """The FE's largest cell stresses over the run's samples, with their times, in the cells
    the checks read (checks.fe_cells_checked: outside the bridging band)."""
    s1, t1, vm, t2 = rec.fe_peak
    return {"max_principal_Pa": s1, "max_principal_t_s": t1, "von_mises_Pa": vm,
            "von_mises_t_s": t2}


def fe_damage(m):
    """What the FE's damage law left: the largest cell damage, in every cell and in those the
    checks read (checks.fe_cells_checked: outside the bridging band), the cells damaged and
    broken (orchestrator.builder.Model.fe_broken), Σ D V (bulk m³) and the energy
    dissipated."""
    fe, checked = m.fe, fe_cells_checked(m)
    return {"max": float(fe.damage.max(initial=0.0)),
            "max_checked": float((fe.damage if checked is None else fe.damage[checked])
                                 .max(initial=0.0)),
            "cells_damaged": int(np.count_nonzero(fe.damage)), "cells": int(fe.damage.size),
            "cells_broken": int(m.fe_broken().sum()),
            "damaged_bulk_volume_m3": float(fe.damage @ fe.cell_volume),
            "dissipated_J": fe.dissipated}


def coupling_figures(c):
    """What summary.json records of the coupling: the solver, r, how many rotation rows
    the diagonal solver's stability guard weakens (the absolute row sum in the lumped
    multiplier: the rotation constraint is then enforced more softly), ρ and its bound (ρ
    None where the bound alone showed r stable: a grown zone's models)."""
    return {"variant": c.variant, "relaxation": c.relaxation, "rotations": c.rotations,
            "bridging_spheres": c.n, "rotation_rows": 3 * c.n if c.rotations else 0,
            "guarded_rotation_rows": c.guarded_rotation_rows,
            "lumping_ratio": c.lumping_ratio, "lumping_ratio_bound": c.lumping_bound}


def write_results(out, title, model, rec, summary_data, arrays=None, quantities=None):
    """summary.json, sensors.csv, damage.npz, sensors.png and damage.png of a finished run;
    with `quantities` (its QoIs), quantities.csv and their arrays in damage.npz."""
    m, times, history = model, np.array(rec.times), np.array(rec.history)
    write_json(out / "summary.json", summary_data)
    write_sensors(out / "sensors.csv", m.sensor_names, times, history)
    if quantities is not None:
        write_quantities(out / QUANTITIES, quantities.names, times, np.array(rec.quantities))
    # where the FE carries damage, what its cells and the spheres weigh in the damaged volume
    fe = ({"fe_centres": m.fe.cell_centres, "fe_volume": m.fe_cell_volumes(),
           "fe_damage": m.fe.damage, "fe_broken": m.fe_broken(),
           "sphere_share": m.sphere_shares()}
          if m.fe_damages else {})
    save_npz(out / "damage.npz", times=np.array(rec.maps_t), damage=np.array(rec.maps),
             positions=m.spheres.ref_pos, radius=m.spheres.radius, in_de_zone=m.in_de_zone,
             **fe, **(arrays or {}), **({} if quantities is None else quantities.arrays()))
    plot_run(out, title, m.sensor_names, times, history, m.spheres.ref_pos, rec.maps[-1])


def write_sensors(path, names, times, history):
    header = ["t"] + [f"{n}_{c}" for n in names for c in "xyz"]
    write_csv(path, header, np.column_stack([times, history.reshape(len(times), -1)]))


QUANTITIES = "quantities.csv"


def write_quantities(path, names, times, values):
    write_csv(path, ["t", *names], np.column_stack([times, values]))


def read_quantities(path):
    """(times, names, values (n_times, n_quantities)) of a quantities.csv."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return data[:, 0], header[1:], data[:, 1:]


def read_sensors(path):
    """(times, names, history (n_times, n_sensors, 3)) of a sensors.csv."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return data[:, 0], [h[:-2] for h in header[1::3]], data[:, 1:].reshape(len(data), -1, 3)


def plot_run(out, title, names, times, history, positions, damage):
    """sensors.png (displacement magnitude and z of each sensor) and damage.png (plan view)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharex=True)
    for i, name in enumerate(names):
        axes[0].plot(times * 1e3, history[:, i, 2] * 1e3, label=name)
        axes[1].plot(times * 1e3, np.linalg.norm(history[:, i], axis=1) * 1e3, label=name)
    axes[0].set(xlabel="time (ms)", ylabel="z displacement (mm)", title=f"{title}: sensors")
    axes[1].set(xlabel="time (ms)", ylabel="|displacement| (mm)")
    axes[0].legend()
    fig.tight_layout()
    save_figure(fig, out / "sensors.png")
    fig, ax = plt.subplots(figsize=(6, 5))
    damage_map(ax, positions, damage, f"{title}: damage (broken / initial links)")
    fig.tight_layout()
    save_figure(fig, out / "damage.png")


def damage_map(ax, positions, damage, title):
    """Plan view of the damage per sphere, the most damaged of a column on top."""
    order = np.argsort(damage)
    sc = ax.scatter(positions[order, 0], positions[order, 1], c=damage[order], s=6,
                    cmap="inferno_r", vmin=0, vmax=1)
    ax.set(xlabel="x (m)", ylabel="y (m)", title=title, aspect="equal")
    ax.figure.colorbar(sc, ax=ax, shrink=0.8)
