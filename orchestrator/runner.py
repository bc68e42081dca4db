"""The run loop shared by every case: step, sample sensors, guard against blow-ups, measure
damage, write ParaView series, then summary.json, sensors.csv, damage.npz, run.log and plots.

A model (cases.slab.SlabModel, orchestrator.case.CaseModel) provides: `dt`, `step()`,
`seconds` (time split of the steps, dict), `fe` (an ElasticModel or None), `damage` (a
LinkDamage over the measured spheres), `bridge_index` and `in_de_zone` (over them),
`sensor_names`, `sensor_positions`, `sensor_displacements()` ((n_sensors, 3)), `energy()`,
`critical` (critical steps), `sphere_count()`, and `stepper` (its CoupledStepper, or None).
"""
import logging
from dataclasses import dataclass
from time import perf_counter

import numpy as np

log = logging.getLogger("orchestrator.run")
log.propagate = False      # run.log only: the console has the progress bar and the summary


@dataclass
class Schedule:
    steps: int
    sample_every: int = 5         # sensor histories
    check_every: int = 50         # energy, blow-up guard, progress bar
    output_every: int = 200       # ParaView frames and damage maps
    checkpoint_every: int = 1000  # checkpoints (orchestrator.restart)

    def __post_init__(self):
        for name in ("steps", "sample_every", "check_every", "output_every", "checkpoint_every"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


def run(model, spheres, schedule, out, title, reference_energy, info=None, arrays=None,
        checks=None, notes=(), quiet=False, resume=False):
    """Run `model` for schedule.steps and write its results folder `out` (already prepared).

    spheres: the BodySet of measured spheres (damage, ParaView); info: entries put first in
    summary.json; arrays: extra entries of damage.npz; checks(final_damage) -> warnings;
    notes: set-up remarks for the log; resume: carry on from the checkpoint in `out`.
    Checkpoints every schedule.checkpoint_every steps and when SIGTERM asks the run to stop
    (then raises restart.Stopped). Returns the summary.
    """
    from orchestrator import restart
    from orchestrator.diagnostics import BlowUpGuard
    from orchestrator.progress import progress
    from orchestrator.results import write_json
    from yade_side.output import SphereSeries

    handler = logging.FileHandler(out / "run.log")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    log.addHandler(handler)
    log.setLevel(logging.INFO)
    try:
        m = model
        stepper = getattr(m, "stepper", None)      # None: a DE-only model
        guard = BlowUpGuard(reference_energy, growth=2.0)
        log.info("%s: %d spheres, %d FE nodes, %d bridging spheres, dt %.4g s (critical %s), "
                 "%d steps", title, m.sphere_count(), 0 if m.fe is None else len(m.fe.nodes),
                 len(m.bridge_index), m.dt, m.critical, schedule.steps)
        for note in notes:
            log.info("note: %s", note)
        meta = {**restart.fingerprint(m, title, schedule.steps), "info": info or {}}
        checkpoints = restart.supported(m)
        if not checkpoints:
            log.info("no checkpoints: the FE state is distributed over MPI ranks")
        if resume:
            rec = restart.load(out, m, meta)
            log.info("resumed from the checkpoint of step %d", rec.n)
        else:
            rec = restart.Record(times=[0.0], history=[m.sensor_displacements()])
        sphere_series = SphereSeries(out / "spheres.pvd", frames=len(rec.maps_t))
        fe_series = None
        if m.fe is not None:
            from fenicsx_side.output import XdmfSeries
            fe_series = XdmfSeries(out / "fe.xdmf", m.fe, frames=len(rec.maps_t))
        output_s = [0.0]
        times, history, energy, maps_t, maps, gaps = (rec.times, rec.history, rec.energy,
                                                      rec.maps_t, rec.maps, rec.gaps)

        def output(t):
            t0 = perf_counter()
            dmg = m.damage.update()
            maps_t.append(t)
            maps.append(dmg)
            spheres.read()
            sphere_series.write(t, spheres.pos, spheres.radius, displacement=spheres.displacement(),
                                velocity=spheres.vel, rotation_speed=spheres.angvel, damage=dmg)
            if fe_series is not None:
                fe_series.write(t)
            output_s[0] += perf_counter() - t0

        def seconds():
            """Time split of this segment and the earlier ones."""
            now = {**m.seconds, "output": output_s[0]}
            return {k: rec.seconds.get(k, 0.0) + now.get(k, 0.0) for k in {*now, *rec.seconds}}

        if not resume:
            output(0.0)
        t_run = perf_counter()
        with restart.StopRequest() as stop, \
                progress(schedule.steps, title, quiet, initial=rec.n) as bar:
            for n in range(rec.n + 1, schedule.steps + 1):
                m.step()
                t = n * m.dt
                if n % schedule.sample_every == 0:
                    times.append(t)
                    history.append(m.sensor_displacements())
                if n % schedule.check_every == 0 or n == schedule.steps:
                    e = m.energy()
                    energy.append((t, e))
                    checked = {"sensor displacements": history[-1]}
                    if m.fe is not None:
                        checked["FE displacement"] = m.fe.u
                    guard.check(n, e, **checked)
                    # energy balance: total, and what the coupling put into the FE model and
                    # created (+) or dissipated (−) itself
                    balance = {}
                    if stepper is not None and stepper.last is not None:
                        meter, (pred, corrected) = stepper.exchange, stepper.last.gaps()
                        gaps.append((t, pred, corrected))
                        balance = {"to_FE": f"{meter.to_fe:.3g} J",
                                   "coupling": f"{meter.net:+.3g} J",
                                   "gap": f"{pred:.2g}>{corrected:.2g}"}
                    bar.set_postfix(t=f"{t * 1e3:.4g} ms", E=f"{e:.4g} J", **balance,
                                    refresh=False)
                    log.info("step %d, t = %.6g s, energy %.6g J%s", n, t, e,
                             "".join(f", {k} {v}" for k, v in balance.items()))
                if n % schedule.output_every == 0 or n == schedule.steps:
                    output(t)
                bar.update()
                if checkpoints and n < schedule.steps and (
                        stop.requested or n % schedule.checkpoint_every == 0):
                    rec.n = n
                    rec.wall_s += perf_counter() - t_run
                    t_run = perf_counter()
                    restart.save(out, rec, m, meta, seconds())
                    log.info("checkpoint at step %d", n)
                    if stop.requested:
                        raise restart.Stopped(f"stopped at step {n} of {schedule.steps}: "
                                              f"resume with --resume {out}")
            wall = rec.wall_s + perf_counter() - t_run
        if fe_series is not None:
            fe_series.close()

        history = np.array(history)
        final = maps[-1]
        volume = 4.0 / 3.0 * np.pi * spheres.radius**3
        warnings = list(checks(final)) if checks else []
        summary = dict(info or {})
        summary.update({
            "n_spheres": m.sphere_count(),
            "n_fe_nodes": 0 if m.fe is None else len(m.fe.nodes),
            "n_bridging_spheres": len(m.bridge_index),
            "steps": schedule.steps, "dt": m.dt, "critical_dt": m.critical,
            "wall_s": wall, "s_per_step": wall / schedule.steps,
            "time_split_s": seconds(),
            "sensors": {name: {"position": np.asarray(m.sensor_positions[i]).tolist(),
                               "peak_displacement": float(np.linalg.norm(history[:, i], axis=1).max()),
                               "peak_displacement_z": float(np.abs(history[:, i, 2]).max())}
                        for i, name in enumerate(m.sensor_names)},
            "damage": {"initial_links": int(m.damage.initial.sum()),
                       "broken_links": int(np.round(final @ m.damage.initial)),
                       "damaged_volume_m3": float(final @ volume),
                       "max_bridging_damage": float(final[m.bridge_index].max(initial=0.0))},
            "energy": energy,
            "constraint_gap": gaps,
            "coupling_energy_J": None if stepper is None else {
                "to_fe": stepper.exchange.to_fe, "net": stepper.exchange.net},
            "warnings": warnings,
        })
        write_json(out / "summary.json", summary)
        write_sensors(out / "sensors.csv", m.sensor_names, np.array(times), history)
        np.savez(out / "damage.npz", times=np.array(maps_t), damage=np.array(maps),
                 positions=spheres.ref_pos, radius=spheres.radius, in_de_zone=m.in_de_zone,
                 **(arrays or {}))
        plot_run(out, title, summary, np.array(times), history, spheres.ref_pos, final)
        for w in warnings:
            log.warning(w)
            print(f"WARNING: {w}")
        log.info("done: %d steps in %.3g s (%.3g ms/step)", schedule.steps, wall,
                 1e3 * wall / schedule.steps)
        return summary
    except Exception as e:
        log.error("run stopped: %s", e)
        raise
    finally:
        log.removeHandler(handler)
        handler.close()


def post_run_checks(fe, bridge_damage, tensile_strength, compressive_strength):
    """The paper's two a-posteriori checks: the FE stays elastic, the bridging spheres stay
    undamaged (else the DE zone is too small)."""
    warnings = []
    if fe is not None:
        s = fe.stress()
        if s.max_principal.max() > tensile_strength:
            warnings.append(f"FE principal stress {s.max_principal.max() / 1e6:.2f} MPa exceeds "
                            f"the tensile strength {tensile_strength / 1e6:.2f} MPa: the DE "
                            f"zone may be too small")
        if s.von_mises.max() > compressive_strength:
            warnings.append(f"FE von Mises stress {s.von_mises.max() / 1e6:.2f} MPa exceeds the "
                            f"compressive strength {compressive_strength / 1e6:.1f} MPa")
    if bridge_damage.size and bridge_damage.max() > 0:
        warnings.append(f"{np.count_nonzero(bridge_damage)} bridging spheres are damaged (max "
                        f"{bridge_damage.max():.2f}): the DE zone may be too small")
    return warnings


def write_sensors(path, names, times, history):
    from orchestrator.results import write_atomic
    header = ["t"] + [f"{n}_{c}" for n in names for c in "xyz"]
    rows = np.column_stack([times, history.reshape(len(times), -1)])
    lines = [",".join(header)] + [",".join(f"{v:.9e}" for v in row) for row in rows]
    write_atomic(path, "\n".join(lines) + "\n")


def read_sensors(path):
    """(times, names, history (n_times, n_sensors, 3)) of a sensors.csv."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return data[:, 0], [h[:-2] for h in header[1::3]], data[:, 1:].reshape(len(data), -1, 3)


def plot_run(out, title, summary, times, history, positions, damage):
    """sensors.png (displacement magnitude and z of each sensor) and damage.png (plan view)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharex=True)
    for i, name in enumerate(summary["sensors"]):
        axes[0].plot(times * 1e3, history[:, i, 2] * 1e3, label=name)
        axes[1].plot(times * 1e3, np.linalg.norm(history[:, i], axis=1) * 1e3, label=name)
    axes[0].set(xlabel="time (ms)", ylabel="z displacement (mm)", title=f"{title}: sensors")
    axes[1].set(xlabel="time (ms)", ylabel="|displacement| (mm)")
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(out / "sensors.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 5))
    damage_map(ax, positions, damage, f"{title}: damage (broken / initial links)")
    fig.tight_layout()
    fig.savefig(out / "damage.png", dpi=120)
    plt.close(fig)


def damage_map(ax, positions, damage, title):
    """Plan view of the damage per sphere, the most damaged of a column on top."""
    order = np.argsort(damage)
    sc = ax.scatter(positions[order, 0], positions[order, 1], c=damage[order], s=6,
                    cmap="inferno_r", vmin=0, vmax=1)
    ax.set(xlabel="x (m)", ylabel="y (m)", title=title, aspect="equal")
    ax.figure.colorbar(sc, ax=ax, shrink=0.8)
