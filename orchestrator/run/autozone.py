"""A DE zone the run finds for itself: the paper's two a-posteriori checks (the FE stays
elastic, the bridging spheres stay undamaged) read during the coupled run; when one trips,
the run stops, the zone grows over the flagged cells plus a margin, and the model is built
again through the one builder and runs from t = 0. The last attempt is therefore exactly a
fixed-zone run with the final zone.

The case gives `build(mask) -> model` (orchestrator.builder.Model of a zone, a mask of
orchestrator.coupling.cells.CellGrid) and `run(model, k) -> summary` (runs attempt k to its
end); the indicators raise Tripped out of model.step.
"""
from dataclasses import dataclass
from time import perf_counter

import numpy as np

from orchestrator.run.checks import fe_cells_checked
from orchestrator.run.restart import Stopped


def stress_level(v):
    """Check of a stress trip level (× ft): None, or what is expected."""
    return None if 0 < v <= 100 else "in (0, 100] (× the tensile strength)"


def omega_level(v):
    return None if 0 < v <= 1 else "in (0, 1] (link damage)"


def damage_level(v):
    return None if 0 < v <= 1 else "in (0, 1] (FE damage)"


def band_level(v):
    return None if 0 < v <= 1 else "in (0, 1] (a bridging sphere's share of broken links)"


def ahead_level(v):
    return None if 0 < v <= 1 else "in (0, 1] (× the trip levels)"


@dataclass(frozen=True)
class TripLevels:
    """When a coupled run stops to grow its DE zone (docs/auto-zone.md). The defaults, with the
    slab's budget (zone.cost 0.5), are the levels at which the grown zone said "clean" only
    where the full ensembles of the same impacts (small and medium scale, 10, 20, 40 m/s,
    seeds 1-3; paper scale, 10 m/s, seeds 1-2) had it within their scatter (docs/auto-zone.md,
    "Trip levels against the ensembles"):
    - stress: largest principal stress of an FE cell outside the band (Watch) ≥ stress × ft,
      where the FE is linear-elastic and cannot crack. Default 2.2: at 2 it said "cannot pay"
      where a zone within the scatter pays (small and medium scale at 20 m/s, paper scale at
      10 m/s), at 2.5 "clean" where its zone is outside (small scale, 20 m/s); the stress it
      reads is the slab's bending, not raised by the coupling next to the band
      (cases/slab/band_stress.py);
    - damage, where the FE carries damage instead (fenicsx_side.damaged): the damage of an FE
      cell outside the band ≥ damage. Default 0.9: the cell is well into its softening (its
      strength down to 0.62-0.75 ft in uniaxial tension, the crack-band law with the scales'
      Gf). At 0.8 the zone grew past the budget or its limit at medium scale, 20 m/s, where
      zones that stay smaller are within the scatter; at 0.95 it ended clean at 40 m/s,
      small and medium scale, and outside (so did 0.9 with the budget at 1, small scale);
    - omega: a link of a bridging sphere with damage ω ≥ omega (a broken link counts as 1).
      Default 1, a broken link: at 0.1 or 0.5 the band's partly damaged links flooded the
      zone to its limit at 10 m/s (with the damaging FE);
    - band (None: off), instead of omega: a bridging sphere whose damage, its share of broken
      links (broken / initial, the paper's measure), is ≥ band; 1: a sphere with no link left,
      a piece loose in the band that the coupling would hold to the FE as a continuum;
    - stress_every, links_every: steps between the two checks (their costs: ~0.03 and ~4-6
      steps of the small coupled slab; 0.24 % and 3-6 % of the run at these defaults);
    - margin: cells added around the flagged ones (≥ 1, so the crack's front is inside);
    - ahead: when one trips, the cells where the same indicator has passed ahead × its level
      are flagged too (1: only those that tripped): fewer, larger growths."""
    stress: float = 2.2
    omega: float = 1.0
    damage: float = 0.9
    stress_every: int = 10
    links_every: int = 100
    margin: int = 1
    ahead: float = 1.0
    band: float = None

    def __post_init__(self):
        for name, check in (("stress", stress_level), ("omega", omega_level),
                            ("damage", damage_level), ("band", band_level)):
            if name == "band" and self.band is None:        # off
                continue
            complaint = check(getattr(self, name))
            if complaint:
                raise ValueError(f"trip_{name} must be {complaint}, got {getattr(self, name)!r}")
        for name in ("stress_every", "links_every", "margin"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if ahead_level(self.ahead):
            raise ValueError(f"ahead must be {ahead_level(self.ahead)}, got {self.ahead!r}")


class Tripped(Exception):
    """An indicator passed its level at `step`; `cells`: the mask of the cells that did;
    `near`: of those past `ahead` × the level (TripLevels.ahead; default `cells`)."""

    def __init__(self, step, indicator, cells, near=None):
        super().__init__(f"zone check tripped at step {step}: {indicator}")
        self.step, self.indicator, self.cells = step, indicator, cells
        self.near = cells if near is None else near | cells

    def grown(self, zone, grid, margin, limit):
        """The zone grown over the flagged cells and `margin` more, inside `limit`; None if
        it cannot grow so (a cell that tripped lies outside the limit, or nothing is new)."""
        grown = (zone | grid.dilate(self.near & limit, margin)) & limit
        if (self.cells & ~limit).any() or not (grown & ~zone).any():
            return None
        return grown

    def beyond(self, limit):
        """How far what tripped lies past `limit` (a mask), in words."""
        outside = int(np.count_nonzero(self.cells & ~limit))
        if outside == 0:
            return "no cell to convert inside it"
        return f"{outside} of the {int(self.cells.sum())} cells that tripped lie outside it"


class Watch:
    """The indicators of one coupled model, read after every `stress_every`-th and
    `links_every`-th step of model.step (which it wraps); they only read the state. The FE's
    stress or damage is read in the cells the post-run check reads, outside the bridging band
    (orchestrator.run.checks.fe_cells_checked)."""

    def __init__(self, model, grid, tensile_strength, levels):
        self.model, self.grid, self.levels = model, grid, levels
        self.limit = levels.stress * tensile_strength
        fe = model.fe
        self.fe_centres = fe.nodes[fe.cell_nodes].mean(axis=1) if fe is not None else None
        self.fe_read = fe_cells_checked(model)
        self.band = model.bridge_index
        self.band_pos = model.spheres.ref_pos[self.band]
        self.steps, self.seconds = 0, 0.0
        self.peak_stress, self.peak_omega, self.peak_damage = 0.0, 0.0, 0.0
        self.peak_band = 0.0
        step = model.step

        def watched():
            step()
            self.steps += 1
            t0 = perf_counter()
            try:
                self._check(self.steps)
            finally:
                self.seconds += perf_counter() - t0
        model.step = watched

    def _check(self, n):
        lv, fe = self.levels, self.model.fe
        if self.fe_centres is not None and n % lv.stress_every == 0:
            if fe.carries_damage:
                d = self._read(fe.damage)
                self.peak_damage = max(self.peak_damage, float(d.max(initial=0.0)))
                _trip(n, d, lv.damage, f"FE damage {d.max():.3g} ≥ {lv.damage:g} in {{}} cells",
                      self.fe_centres, self.grid, lv.ahead)
            else:
                s1 = self._read(fe.stress().max_principal)
                self.peak_stress = max(self.peak_stress, float(s1.max(initial=0.0)))
                _trip(n, s1, self.limit, f"FE σ1 {s1.max() / 1e6:.3g} MPa ≥ {lv.stress:g} × ft "
                                         f"in {{}} cells", self.fe_centres, self.grid, lv.ahead)
        if self.band.size and n % lv.links_every == 0:
            if lv.band is not None:         # the spheres' share of broken links
                share = self.model.damage.update()[self.band]
                self.peak_band = max(self.peak_band, float(share.max(initial=0.0)))
                _trip(n, share, lv.band, f"bridging sphere damage {share.max():.3g} ≥ "
                                         f"{lv.band:g} at {{}} spheres", self.band_pos,
                      self.grid, lv.ahead)
            else:                           # their most damaged link
                worst = self.model.damage.worst_link()[self.band]
                self.peak_omega = max(self.peak_omega, float(worst.max(initial=0.0)))
                _trip(n, worst, lv.omega, f"bridging link ω {worst.max():.3g} ≥ {lv.omega:g} "
                                          f"at {{}} spheres", self.band_pos, self.grid, lv.ahead)

    def _read(self, values):
        """The cells' values, 0 in the band's cells."""
        return values if self.fe_read is None else np.where(self.fe_read, values, 0.0)


def _trip(n, values, level, text, positions, grid, ahead=1.0):
    """Tripped at step n if any of `values` reaches `level`: `text` with their count, the
    cells of the `positions` of those past ahead × level flagged."""
    over = values >= level
    if over.any():
        raise Tripped(n, text.format(np.count_nonzero(over)), grid.cells_of(positions[over]),
                      grid.cells_of(positions[values >= ahead * level]))


@dataclass
class Outcome:
    status: str            # "clean": a run ended with no trip; "limit": the zone would pass it,
                           # or another attempt would cost more than the budget allows
    limit: str             # None (clean), "cells" (the zone's limit) or "cost" (the budget)
    zone: np.ndarray       # the last zone run
    zones: list            # the zone of every attempt
    attempts: list         # per attempt: its figures (dicts)
    summary: dict          # the last attempt's summary (None if it tripped)
    wall_s: float          # every attempt, failed ones included
    s_per_sphere_step: float   # YADE's cost per sphere and step, measured in the attempts

    def record(self, grid, full_spheres, steps):
        """What summary.json keeps of the search, with the full model's projected cost
        (its spheres × YADE's per-sphere step cost measured here × the steps)."""
        return {"zone_outcome": self.status, "zone_limit_reached": self.limit,
                "zone_attempts": self.attempts,
                "zone_final": {"cells": np.argwhere(self.zone).tolist(),
                               "n_cells": int(self.zone.sum()),
                               "grid": {"p0": grid.p0.tolist(), "p1": grid.p1.tolist(),
                                        "n": grid.n.tolist(), "axes": grid.axes}},
                "zone_total_wall_s": self.wall_s,
                "full_model_projected": {
                    "spheres": int(full_spheres), "steps": int(steps),
                    "s_per_sphere_step": self.s_per_sphere_step,
                    "wall_s": self.s_per_sphere_step * full_spheres * steps}}


def check_zones(grid, start, limit):
    start, limit = grid.check(start, "start zone"), grid.check(limit, "zone limit")
    if (start & ~limit).any():
        raise ValueError(f"zone limit ({int(limit.sum())} cells) does not hold the start zone "
                         f"({int(start.sum())} cells): widen the limit or shrink the start")


def find_zone(build, run, grid, start, limit, tensile_strength, levels, log=print,
              budget=None):
    """Attempts from the zone `start` (a mask of `grid`) until one runs with no trip, or the
    zone would pass `limit` (a flagged cell outside it, or a zone that fills it and still
    trips), or `budget(attempts)` (None: no budget) says why another attempt cannot pay;
    returns the Outcome."""
    check_zones(grid, start, limit)
    zone, zones, attempts, t_all = start.copy(), [], [], perf_counter()
    cost = []                                 # (YADE seconds, sphere steps) of each attempt
    while True:
        t0 = perf_counter()
        model = build(zone)
        watch = Watch(model, grid, tensile_strength, levels)
        tripped, summary = None, None
        try:
            summary = run(model, len(attempts))
        except Tripped as t:
            tripped = t
        except Stopped:                 # SIGTERM: attempts restart from t = 0, no resume
            raise Stopped(f"attempt {len(attempts) + 1} of the zone search was stopped; an "
                          f"auto-zone run does not resume: run it again") from None
        cost.append((model.seconds["yade"], watch.steps * model.sphere_count()))
        zones.append(zone.copy())
        attempts.append({
            "cells": int(zone.sum()), "zone_cells": np.argwhere(zone).tolist(),
            "spheres": int(model.sphere_count()),
            "fe_nodes": 0 if model.fe is None else len(model.fe.nodes),
            "bridging_spheres": int(len(model.bridge_index)), "steps_run": watch.steps,
            "tripped_step": None if tripped is None else tripped.step,
            "indicator": None if tripped is None else tripped.indicator,
            "peak_fe_stress_Pa": watch.peak_stress, "peak_band_omega": watch.peak_omega,
            "peak_fe_damage": (watch.peak_damage if model.fe is not None
                               and model.fe.carries_damage else None),
            "indicator_s": watch.seconds, "wall_s": perf_counter() - t0})
        log(f"zone attempt {len(attempts)}: {int(zone.sum())} cells, "
            f"{model.sphere_count()} spheres: "
            + ("ran clean" if tripped is None else str(tripped)))
        if tripped is None:
            status, reached = "clean", None
            break
        # flagged cells beyond the limit end the search; the margin stops at the limit
        grown = tripped.grown(zone, grid, levels.margin, limit)
        if grown is None:
            status, reached = "limit", "cells"
            attempts[-1]["beyond_limit"] = tripped.beyond(limit)
            break
        why = None if budget is None else budget(attempts)
        if why:
            log(f"zone search ends: {why}")
            status, reached = "limit", "cost"
            break
        zone = grown
    seconds, sphere_steps = np.sum(cost, axis=0)
    return Outcome(status, reached, zone, zones, attempts, summary, perf_counter() - t_all,
                   float(seconds / sphere_steps) if sphere_steps else float("nan"))


def plot_zones(path, grid, outcome, limit, title, joined="attempt the cell joined"):
    """Plan of the structure (a grid of two axes) coloured by the zone (outcome.zones: the
    attempts', or a growing zone's) in which each cell joined, with the limit's outline;
    `joined`: the colour bar's label."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from common.files import save_figure
    first = np.full(grid.shape, np.nan)
    for k, z in reversed(list(enumerate(outcome.zones))):
        first[z] = k + 1
    (x0, y0), (x1, y1) = grid.p0[grid.axes], grid.p1[grid.axes]
    fig, ax = plt.subplots(figsize=(6.5, 5))
    img = ax.imshow(first.T, origin="lower", extent=(x0, x1, y0, y1), cmap="viridis", vmin=1,
                    vmax=max(1, len(outcome.zones)), interpolation="nearest")
    ax.add_collection(LineCollection(_outline(limit, (x0, y0), grid.size[grid.axes]),
                                     colors="red", linewidths=1.5))
    ax.set(xlabel="x (m)", ylabel="y (m)", aspect="equal",
           title=f"{title}\n({outcome.status}; red: limit)")
    fig.colorbar(img, ax=ax, shrink=0.8, label=joined,
                 ticks=np.arange(1, len(outcome.zones) + 1))
    fig.tight_layout()
    save_figure(fig, path)


def _outline(mask, origin, size):
    """Segments of the cell edges between the cells of `mask` and the others (or the
    grid's border)."""
    m = np.pad(np.asarray(mask, bool), 1)
    (x0, y0), (dx, dy) = origin, size
    i, j = np.nonzero(m[1:, 1:-1] != m[:-1, 1:-1])       # edge x = x0 + i dx along cell j
    segs = [((x0 + a * dx, y0 + b * dy), (x0 + a * dx, y0 + (b + 1) * dy)) for a, b in zip(i, j)]
    i, j = np.nonzero(m[1:-1, 1:] != m[1:-1, :-1])       # edge y = y0 + j dy along cell i
    segs += [((x0 + a * dx, y0 + b * dy), (x0 + (a + 1) * dx, y0 + b * dy)) for a, b in zip(i, j)]
    return segs
