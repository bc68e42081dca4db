"""Coupled against full (`compare FULL COUPLED`): one run of each, or ensembles of runs over
packing seeds. Each same-seed pair is compared sensor by sensor and sphere by sphere (the
coupled slab's spheres are a subset of the full one's: the same packing); with two or more
full members, the coupled runs are also judged against the full model's own scatter
(orchestrator.ensemble, orchestrator.verdicts). Writes comparison.json and PNGs.
The compared side may also be full runs of another setting (a time step, the shear release):
they are judged the same way, under the key "coupled"; same-seed members must cover the
same time. Full runs of another zone judge the coupled runs on the QoIs alone (their
sensors sit elsewhere: sensors_apart)."""
import json
from pathlib import Path

import numpy as np

from cases.slab import compare_page, judge
from common.files import save_figure, write_json
from orchestrator import ensemble, verdicts
from orchestrator.run.outputs import QUANTITIES, damage_map, read_quantities, read_sensors

# the keys a full and a coupled member must share to be compared (and their duration: the
# step may differ)
SAME = ("scale", "radius", "impactor_speed", "impactor_side", "impactor_gap", "de_zone",
        "full_width", "layers", "band_ratio", "concrete")
# those that only place the sensors: runs of other zones compare on their QoIs alone
ZONE_KEYS = ("de_zone", "full_width", "layers", "band_ratio")
PLAN_CELL = 0.05   # m, the plan grid of the mean damage maps


class Run:
    """A slab results folder, read back."""

    def __init__(self, folder):
        self.folder = Path(folder)
        summary = self.folder / "summary.json"
        if not summary.is_file():
            raise FileNotFoundError(f"{self.folder} is not a slab results folder (no summary.json)")
        try:
            self.summary = json.loads(summary.read_text())
        except (OSError, ValueError) as e:
            raise ValueError(f"{summary}: unreadable ({e})") from None
        if "spec" not in self.summary or "model" not in self.summary:
            raise ValueError(f"{self.folder} holds a run of case {self.summary.get('case')!r} "
                             f"({self.summary.get('kind')}), not a slab run: compare takes full "
                             f"and coupled slab runs")
        for name in ("sensors.csv", "damage.npz"):
            if not (self.folder / name).is_file():
                raise FileNotFoundError(f"{self.folder} has no {name}: not a finished slab run")
        self.model, self.spec = self.summary["model"], self.summary["spec"]
        self.spec.setdefault("concrete", "plain")    # runs made before the choice existed
        if self.spec.get("zone") == "grow" and self.spec.get("zone_start") is not None:
            # a growing zone reads the sensors of its start zone: a square of side zone_start
            self.spec.update(de_zone=self.spec["zone_start"], full_width=False)
        self.seed = self.spec.get("seed", 1)
        self.t, self.names, self.h = read_sensors(self.folder / "sensors.csv")
        # the quantities of interest (None: a run recorded before them)
        self.quantities = None
        if (self.folder / QUANTITIES).is_file():
            self.quantities = read_quantities(self.folder / QUANTITIES)
        with np.load(self.folder / "damage.npz") as d:
            self.damage = {k: d[k] for k in d.files}


def members(folders, model):
    """{seed: Run} of run folders or ensemble folders (seed-N subfolders, `slab --seeds`) of
    the model `model` (or of one of the models `model`)."""
    runs = {}
    for folder in map(Path, folders):
        parts = sorted(folder.glob("seed-*/summary.json")) if not (folder / "summary.json").is_file() \
            else [folder / "summary.json"]
        if not parts:
            raise FileNotFoundError(f"{folder} is not a slab results folder (no summary.json) "
                                    f"nor an ensemble of them (no seed-*/summary.json)")
        for part in parts:
            run = Run(part.parent)
            if run.model not in (model if isinstance(model, tuple) else (model,)):
                raise ValueError(f"{run.folder} holds a {run.model!r} slab run, expected {model!r} "
                                 f"(compare FULL COUPLED)")
            if run.seed in runs:
                raise ValueError(f"two {run.model} runs have seed {run.seed}: "
                                 f"{runs[run.seed].folder} "
                                 f"and {run.folder}")
            runs[run.seed] = run
    return runs


def load(full_dirs, coupled_dirs, verdict=False):
    """({seed: Run} full, {seed: Run} coupled), checked comparable; `verdict`: a verdict
    is asked for, which needs the members the equivalence test needs (judge.check_members)
    and the quantities of interest, recorded alike in every run."""
    full, coupled = members(full_dirs, "full"), members(coupled_dirs, ("coupled", "full"))
    if verdict:
        judge.check_members(len(full), len(coupled), len(full.keys() & coupled.keys()))
    if verdict or any(r.quantities is not None for r in [*full.values(), *coupled.values()]):
        _check_quantities([*full.values(), *coupled.values()])
    apart = sensors_apart(full, coupled)
    if apart:
        _check_apart(full, coupled)
    same = [k for k in SAME if not (apart and k in ZONE_KEYS)]
    ensemble.check_same_kind({f"{r.model} {s}": {k: r.spec.get(k) for k in same}
                              for runs in (full, coupled) for s, r in runs.items()})
    names = next(iter(full.values())).names
    for r in [*full.values(), *coupled.values()]:
        if r.names != names:
            raise ValueError(f"{r.folder}: sensors {r.names}, the others {names}")
    for seed in full.keys() & coupled.keys():
        _check_duration(full[seed], coupled[seed])
    # one window for every member, the QoIs' too: the same steps of the same fraction of
    # the critical step (each seed's critical step differs by a few %)
    ensemble.check_same_kind({f"{r.model} {s}": {"window (steps × dt_safety)": _window(r)}
                              for runs in (full, coupled) for s, r in runs.items()})
    return full, coupled


def _window(run):
    steps, safety = run.spec.get("steps"), run.spec.get("dt_safety")
    return (round(steps * safety, 9) if isinstance(safety, (int, float)) and steps
            else steps)


def judged(full, coupled):
    """The runs are judged on the quantities of interest: they recorded them (runs made
    before them are compared on their sensors alone) and the test has its members."""
    if any(r.quantities is None for r in [*full.values(), *coupled.values()]):
        return False
    try:
        judge.check_members(len(full), len(coupled), len(full.keys() & coupled.keys()))
    except ValueError:
        return False
    return True


def _check_quantities(runs):
    """Every run recorded the quantities of interest, with the same definitions (asked of
    a verdict, and of runs of which some recorded them: none mixes the two)."""
    for r in runs:
        if r.quantities is None:
            raise ValueError(f"{r.folder} has no {QUANTITIES}: a run recorded before the "
                             f"quantities of interest, which the verdict judges; run it again")
    definition = lambda r: {k: v for k, v in r.summary["quantities"].items()
                            if k in ("version", "names", "patch_radius_m", "profile_x_m",
                                     "profile_y_m")}
    ensemble.check_same_kind({f"{r.model} {r.seed} ({r.folder})": definition(r) for r in runs})


def sensors_apart(full, coupled):
    """The full runs' single-sphere sensors sit at another zone's points than the compared
    runs' (another de_zone, width, layers or band): only the quantities of interest, which
    every model places alike, can be compared."""
    f, c = next(iter(full.values())), next(iter(coupled.values()))
    return any(f.spec.get(k) != c.spec.get(k) for k in ZONE_KEYS)


def _check_apart(full, coupled):
    """Runs of other zones compare on their QoIs alone: every run has them, and no full run
    kept its links elastic outside its own zone (that zone is then physics, not a place)."""
    f, c = next(iter(full.values())), next(iter(coupled.values()))
    zones = ", ".join(f"{k} {f.spec.get(k)!r} vs {c.spec.get(k)!r}" for k in ZONE_KEYS
                      if f.spec.get(k) != c.spec.get(k))
    for r in [*full.values(), *coupled.values()]:
        if r.quantities is None:
            raise ValueError(f"the runs differ in their zones ({zones}) and {r.folder} has no "
                             f"{QUANTITIES}: runs of other zones compare only on the "
                             f"quantities of interest; run it again")
        if r.spec.get("elastic_outside"):
            raise ValueError(f"the runs differ in their zones ({zones}) and {r.folder} kept its "
                             f"links elastic outside its own zone: compare it with runs of "
                             f"that zone")


def _check_duration(f, c):
    """A same-seed pair must cover the same time (to a sample interval), whatever its steps
    (the step follows the packing's smallest sphere: seeds differ by a few %)."""
    spacing = max(r.t[-1] - r.t[-2] for r in (f, c) if len(r.t) > 1)
    if abs(f.t[-1] - c.t[-1]) > spacing * (1 + 1e-9):
        raise ValueError(f"members differ in duration: {1e3 * f.t[-1]:.4g} ms ({f.folder}) vs "
                         f"{1e3 * c.t[-1]:.4g} ms ({c.folder})")


def compare(full, coupled, out, verdict=False, margin=None):
    """comparison.json and PNGs in `out` for the runs of `load`: with the members the
    equivalence test needs, the QoIs judged (judge.judge, `margin`: its margins) and the
    sensors against the full scatter (given anyway with two or more full runs)."""
    names = next(iter(full.values())).names
    apart = sensors_apart(full, coupled)
    pairs = {s: pair(full[s], coupled[s], sensors=not apart)
             for s in sorted(full.keys() & coupled.keys())}
    result = {"full": [str(r.folder) for r in full.values()],
              "coupled": [str(r.folder) for r in coupled.values()], "pairs": pairs}
    if len(pairs) == 1 and len(full) == len(coupled) == 1:
        result.update(next(iter(pairs.values())))         # one pair: its figures at the top
    result["warnings"] = last_sample_warnings(pairs)
    if apart:
        result["warnings"].append(
            "the full runs' single-sphere sensors sit at another zone's points than the "
            "compared runs': only the quantities of interest are compared")
    if verdict or judged(full, coupled):
        result["judgement"] = judgement(full, coupled, margin)
        result["headline"] = judge.headline(result["judgement"])
        result["cracking_map_correlation"] = _cracking_maps(out, full, coupled)
        short = judge.window_warning(result["judgement"])
        result["warnings"] += [short] if short else []
        _plot_quantities(out / "quantities.png", full, coupled)
        _plot_profiles(out / "profiles.png", full, coupled)
    result["energy_split"] = _energy_splits(full, coupled)
    if result["energy_split"] is None and any(
            _split(r) is not None for runs in (full, coupled) for r in runs.values()):
        result["warnings"].append("the energy split is not compared: a run was made before "
                                  "it was recorded, or with another definition of it")
    if not apart and (verdict or len(full) >= verdicts.MIN_FULL_MEMBERS):
        result["ensemble"] = _ensemble(full, coupled, names, out)
    write_json(out / "comparison.json", result)
    for seed in pairs:
        _plot_pair(out, compare_page.pair_suffix(seed, len(pairs)),
                   [] if apart else names, full[seed], coupled[seed])
    compare_page.write(result, full, coupled, out)
    return result


def judgement(full, coupled, margin=None):
    """The yardstick's judgement (judge.judge) of the runs of `load` on their quantities of
    interest and their cracking energy."""
    return judge.judge(_quantities(full), _quantities(coupled), margin,
                       _cracking_totals(full, coupled))


def last_sample_warnings(pairs):
    """One line per pair whose sensors peak at the compared window's last sample: their
    'peaks' are where the window ends, not the response's."""
    lines = []
    for seed, p in pairs.items():
        cut = [f"{name} ({', '.join(s['peak_is_last_sample'])})"
               for name, s in p["sensors"].items() if s["peak_is_last_sample"]]
        if cut:
            lines.append(f"seed {seed}: the peaks of {', '.join(cut)} are the last sample "
                         f"(t = {p['compared_until_s'] * 1e3:.3g} ms): the response was still "
                         f"growing when the window ended; peak ratios and nRMS judge the "
                         f"window, not the peak (run more --steps)")
    return lines


def pair(f, c, sensors=True):
    """A same-seed pair: sensor peaks, nRMS and peak times (z), damage sphere by sphere in
    the DE zone, cost, and the slab issue's goals (`sensors` False: the sensors sit at other
    points, sensors_apart; neither they nor the goals that read them are given)."""
    t_end = min(f.t[-1], c.t[-1])
    t = f.t[f.t <= t_end]
    names, sensors = (f.names if sensors else []), {}
    for i, name in enumerate(names):
        fz, cz = f.h[f.t <= t_end, i, 2], np.interp(t, c.t, c.h[:, i, 2])
        peak_f, peak_c = np.abs(fz).max(), np.abs(cz).max()
        sensors[name] = {
            "peak_full": peak_f, "peak_coupled": peak_c,
            "peak_time_full_s": t[np.argmax(np.abs(fz))],
            "peak_time_coupled_s": t[np.argmax(np.abs(cz))],
            "peak_ratio": _one(ensemble.ratio(peak_c, peak_f)),
            "nrms": _one(ensemble.nrms(cz[:, None], fz[:, None])),
            # a peak at the window's last sample is where the window cut a growing response
            "peak_is_last_sample": [side for side, z in (("full", fz), ("coupled", cz))
                                    if np.argmax(np.abs(z)) == len(t) - 1]}
    damage = _pair_damage(f, c)
    sf, sc = f.summary, c.summary
    return {
        "compared_until_s": t_end, "full_elastic_outside": f.spec.get("elastic_outside", False),
        "sensors": sensors, "damage": damage,
        "speedup_per_step": sf["s_per_step"] / sc["s_per_step"],
        "sphere_count_ratio": sf["n_spheres"] / sc["n_spheres"],
        "projected_100k_steps_s": {"full": 1e5 * sf["s_per_step"],
                                   "coupled": 1e5 * sc["s_per_step"]},
        "goals": verdicts.absolute_goals({k: v["nrms"] for k, v in sensors.items()},
                                         {k: v["peak_ratio"] for k, v in sensors.items()},
                                         damage["damaged_volume_ratio"]) if names else None,
    }


def _one(value):
    """A figure for JSON: None where undefined (a zero reference)."""
    return ensemble.figures(value)[0]


def _pair_damage(f, c):
    match, d_full, d_coupled, in_zone = _matched_damage(f, c)
    vol_c = 4.0 / 3.0 * np.pi * c.damage["radius"] ** 3
    sf, sc = f.summary["damage"], c.summary["damage"]
    return {
        "broken_links_full": sf["broken_links"], "broken_links_coupled": sc["broken_links"],
        "damaged_volume_full_m3": sf["damaged_volume_m3"],
        "damaged_volume_coupled_m3": sc["damaged_volume_m3"],
        "damaged_volume_ratio": _one(ensemble.ratio(sc["damaged_volume_m3"],
                                                    sf["damaged_volume_m3"])),
        "damage_map_correlation_de_zone": ensemble.correlation(d_full[in_zone], d_coupled[in_zone]),
        "damaged_volume_de_zone_full_m3": float(d_full[in_zone] @ vol_c[in_zone]),
        "damaged_volume_de_zone_coupled_m3": float(d_coupled[in_zone] @ vol_c[in_zone]),
    }


def _matched_damage(f, c):
    """The final damage of the full run at the coupled run's spheres (same packing)."""
    where = {int(k): j for j, k in enumerate(f.damage["slab_index"])}
    match = np.array([where[int(k)] for k in c.damage["slab_index"]], int)
    return match, f.damage["damage"][-1][match], c.damage["damage"][-1], c.damage["in_de_zone"]


def _quantities(runs):
    return {s: r.quantities for s, r in runs.items()}


def _plot_profiles(path, full, coupled):
    """Each member's deflection along the span's centre line at its centre's peak (full
    solid, compared dashed, a colour per seed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from cases.slab.quantities import peak_figures
    fig, ax = plt.subplots(figsize=(8, 4.5))
    seeds = sorted(full.keys() | coupled.keys())
    for side, runs, style in (("full", full, "-o"), (_side(coupled.values()), coupled, "--s")):
        for s, r in sorted(runs.items()):
            p = peak_figures(r.quantities[0], r.quantities[2])["profile_at_peak"]
            ax.plot(p["x_m"], 1e3 * np.array(p["deflection_m"]), style, ms=3, lw=1,
                    color=f"C{seeds.index(s) % 10}",
                    label=f"{side} {s} ({1e3 * p['time_s']:.2f} ms)")
    ax.set(xlabel="x along the span's centre line (m)", ylabel="z deflection of the bottom (mm)",
           title="the deflection profile at the centre's peak")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path)


def _cracking_totals(full, coupled):
    """{"cracking_energy": (full, coupled {seed: J})}: the slab's energy dissipated by
    cracking (cases.slab.quantities), where every run measured it, else {}."""
    energy = {side: {s: (r.summary["quantities"].get("cracking_energy") or {}).get("slab_J")
                     for s, r in runs.items()} for side, runs in (("f", full), ("c", coupled))}
    if any(v is None for side in energy.values() for v in side.values()):
        return {}
    return {"cracking_energy": (energy["f"], energy["c"])}


def _energy_splits(full, coupled):
    """{"full", "coupled": the members' mean energy split at the window's end
    (cases.slab.energies.figures: input, residual, {term: {region: J}}), "members"}; None
    unless every run recorded one, of one definition."""
    splits = {side: [_split(r) for r in runs.values()]
              for side, runs in (("full", full), ("coupled", coupled))}
    every = [s for side in splits.values() for s in side]
    if any(s is None for s in every) or len({s["version"] for s in every}) > 1:
        return None
    out = {"members": {side: len(v) for side, v in splits.items()}}
    for side, members in splits.items():
        mean = lambda get: float(np.mean([get(s) for s in members]))     # noqa: E731
        out[side] = {"input_J": mean(lambda s: s["input_J"]),
                     "residual_J": mean(lambda s: s["residual_J"]),
                     "terms": {t: {r: mean(lambda s: s["terms"][t][r]) for r in regions}
                               for t, regions in members[0]["terms"].items()}}
    return out


def _split(run):
    """The energy split a run recorded (cases.slab.energies.figures), or None."""
    return (run.summary.get("quantities") or {}).get("energy_split")


def _cracking_maps(out, full, coupled):
    """cracking_maps.png: the mean energy dissipated by cracking per plan cell of the FE grid
    (J), full beside coupled (the paper's Fig. 10 in energy), and the two maps' correlation
    (None without the measure)."""
    from cases.slab.zone import plan_cell
    runs = [*full.values(), *coupled.values()]
    if any("crack_energy" not in r.damage for r in runs):
        return None
    cell = plan_cell(runs[0].spec)
    mean = lambda members: np.mean([ensemble.plan_sum(r.damage["crack_points"],
                                                      r.damage["crack_energy"], (0, 0),
                                                      (2.5, 2.0), cell)[0]
                                    for r in members.values()], axis=0)
    f, c = mean(full), mean(coupled)
    x, y = ensemble.plan_sum(np.zeros((1, 3)), [0.0], (0, 0), (2.5, 2.0), cell)[1:]
    corr = ensemble.correlation(f.ravel(), c.ravel())
    from orchestrator.ensemble_plots import plot_plan_maps
    plot_plan_maps(out / "cracking_maps.png", x, y, {"full": f, _side(coupled.values()): c},
                   "energy dissipated by cracking per cell (J)",
                   f"mean of {len(full)} full and {len(coupled)} compared seeds; correlation "
                   + ("undefined" if corr is None else f"{corr:.3f}"))
    return corr


def _plot_quantities(path, full, coupled):
    """The judged QoIs of every member: full solid, coupled dashed, one colour per seed."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from cases.slab.quantities import UNITS, kind
    names = list(judge.JUDGED)
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(18, 7.5), sharex=True)
    seeds = sorted(full.keys() | coupled.keys())
    for ax, name in zip(axes.T.ravel(), names):
        for side, runs, style in (("full", full, "-"), (_side(coupled.values()), coupled, "--")):
            for s, r in sorted(runs.items()):
                t, qnames, v = r.quantities
                scale, unit = UNITS[kind(name)]
                ax.plot(t * 1e3, v[:, qnames.index(name)] * scale, style, lw=1,
                        color=f"C{seeds.index(s) % 10}",
                        label=f"{side} {s}" if name == names[0] else None)
        ax.set(title=name, xlabel="time (ms)", ylabel=unit)
    axes.T.ravel()[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path)


def _ensemble(full, coupled, names, out):
    """The coupled members against the full ensemble: scatter, deviations, verdicts."""
    from orchestrator.ensemble_plots import plot_histories, plot_mean_damage_maps
    z = lambda runs: {s: (r.t, r.h[:, :, 2]) for s, r in runs.items()}
    hist = ensemble.histories(z(full), z(coupled), names)
    figures = lambda runs: {s: r.summary["damage"] for s, r in runs.items()}
    dmg = ensemble.damage(figures(full), figures(coupled))
    maps = ensemble.mean_damage_maps(_maps(full), _maps(coupled, de_zone=True), (0.0, 0.0),
                                     (2.5, 2.0), PLAN_CELL)
    labels = ("full", _side(coupled.values()))
    plot_histories(out / "ensemble_histories.png", z(full), z(coupled), names,
                   ylabel="z displacement (mm)", labels=labels)
    plot_mean_damage_maps(out / "ensemble_damage_maps.png", maps, len(full), len(coupled),
                          labels)
    result = {"histories": hist, "damage": dmg,
              "mean_damage_map_correlation": maps["correlation"],
              "goals": verdicts.ensemble_goals(hist, dmg)}
    if coupled:
        result["within_full_scatter"] = verdicts.within_full_scatter(hist, dmg)
    return result


def _side(runs):
    """How the plots name the compared `runs`: "coupled", or "compared" when full runs of
    another setting are among them."""
    return "coupled" if all(r.model == "coupled" for r in runs) else "compared"


def _maps(runs, de_zone=False):
    """{seed: (positions, final damage, volume)}: for coupled runs with an elastic FE, the DE
    zone's spheres only; where the FE carries damage, every sphere and every FE cell, measured
    and weighted as in the damaged volume (orchestrator.builder.Model.damaged_volume)."""
    out = {}
    for s, r in runs.items():
        d = r.damage
        volume = 4.0 / 3.0 * np.pi * d["radius"] ** 3
        if "fe_damage" in d:
            out[s] = (np.vstack([d["positions"], d["fe_centres"]]),
                      np.concatenate([d["damage"][-1], d["fe_broken"]]),
                      np.concatenate([volume * d["sphere_share"], d["fe_volume"]]))
            continue
        keep = d["in_de_zone"] if de_zone else np.ones(len(d["radius"]), bool)
        out[s] = (d["positions"][keep], d["damage"][-1][keep], volume[keep])
    return out


def _plot_pair(out, suffix, names, f, c):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    if names:
        fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
        for ax, i, name in zip(axes.ravel(), range(len(names)), names):
            for label, r, style in (("full", f, "-"), (_side([c]), c, "--")):
                ax.plot(r.t * 1e3, r.h[:, i, 2] * 1e3, style, label=label)
            ax.set(title=name, xlabel="time (ms)", ylabel="z displacement (mm)")
            ax.legend()
        fig.tight_layout()
        save_figure(fig, out / f"histories{suffix}.png")
    _, d_full, d_coupled, in_zone = _matched_damage(f, c)
    positions = c.damage["positions"][in_zone]
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    damage_map(axes[0], positions, d_full[in_zone], f"full (seed {f.seed}): damage in the DE zone")
    damage_map(axes[1], positions, d_coupled[in_zone],
               f"{_side([c])} (seed {c.seed}): damage in the DE zone")
    fig.tight_layout()
    save_figure(fig, out / f"damage_maps{suffix}.png")
