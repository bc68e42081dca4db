"""The runs of the study "where coupling pays" (docs/where-coupling-pays.md): which slab runs,
in which folders, at what projected cost, and which are already done.

The default plan fits BUDGET_S on one quiet core (2.75 h projected; 2.5 h when `make
validate`'s medium 40 m/s ensembles are reused). Medium scale, plain concrete, impacts of
10 and 40 m/s (20 m/s with `--velocities 10,20,40` or `--sweep full`):
- the full ensemble (seeds 1, 2, 3) of every impact;
- the automatic-zone coupled model on seed 1; on seeds 2 and 3 when seed 1 ends clean (a
  search that reaches its limit says that coupling cannot pay for the impact; another seed
  would spend the failed search again);
- the study's DE zone (STUDY_ZONE: the full-width strip, n_b = 3) on seed 1, and the same
  zone with a graded FE mesh (band cells of GRADED_BAND sphere diameters,
  `SlabSpec.band_ratio`);
- at SWEEP_VELOCITY only, on seed 1: the fixed zones × n_b = 1, 2, 3: the default strip, a
  larger strip and a small box (the cheap end of the map: no full-width strip can be 5x
  cheaper at medium scale);
- a fixed zone that qualifies on seed 1: on seeds 2 and 3 too (confirmations), judged on all;
and at paper scale the configuration the medium map says pays (else the paper scale's own
zone), coupled against full over 5 ms after contact, one seed. `--sweep full`: every velocity,
the sweep at each, the default zone and the automatic one on seeds 1-3, the reinforced slab
(its full ensemble, the default zone and the automatic one on seeds 1-3), two paper seeds
(about 8.6 h).

Costs are projections from the recorded benchmark (bench/results.json, `make bench`: CPU time
per step of each model in the impact window, one thread): per step of a coupled model,
YADE's cost per sphere (incl. output) in the benchmark's coupled model × spheres + the
coupling's per bridging sphere × bridging spheres + the FE's per node × nodes, with the counts
of each zone estimated from its share of the slab (within 2 % of the benchmark's models). An
automatic-zone search costs AUTO_OVER_FULL × the full run (docs/auto-zone.md). A loaded core
is slower by its load factor.
"""
import json
import math
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from pathlib import Path

from cases.slab.scales import SLAB, STEPS_SAFETY
from cases.slab.spec import SlabSpec

VELOCITIES = (10.0, 20.0, 40.0)          # m/s, the study's
DEFAULT_VELOCITIES = (10.0, 40.0)        # the default plan's: the budget
SEEDS = (1, 2, 3)
SWEEP_VELOCITY = 10.0     # the default plan's fixed-zone × band sweep: the least damage, the
                          # best chance for a cheap zone (at 40 m/s the medium strip misses
                          # already, docs/slab.md)
SWEEP_LAYERS = (1, 2, 3)
# the map's default zone and band per scale (de_zone, full_width, layers), where its full
# members' sensors sit: the full-width strip with three layers (the slab's default before the
# grown 0.5 m box); paper scale: the slab's own default, the 0.5 m box with one layer
STUDY_ZONE = {"small": (0.6, True, 3), "medium": (0.9, True, 3)}
# the larger fixed zone per scale: a full-width strip midway between the default and the
# auto-zone limit (1.7 m at medium: the slab less the 3-layer band and one FE cell per support)
LARGER_ZONE = {"small": 1.2, "medium": 1.3}
SMALL_BOX = 0.5           # m, a square box: about 9x fewer spheres at medium scale, n_b = 1
GRADED_BAND = 2.0         # band cells / sphere diameter of the graded-mesh row (the scale's
                          # zone, n_b = 3): a 1.6x thinner band at medium scale
PAPER_WINDOW_S = 5e-3     # the paper pair: at least this long after contact
BUDGET_S = 3 * 3600.0     # one core
# the reinforced slab (`SlabSpec.reinforced`, docs/reinforcement.md) is an impact of its own:
# its full ensemble, the default zone and the automatic one, in the full sweep only
REINFORCED_ROWS = ("in `--sweep full` only (each velocity: its full ensemble, the default "
                   "zone and the automatic one, seeds 1-3, `slab --reinforced`'s default mesh); "
                   "at the default plan's two velocities they would add about 1.4 h of one "
                   "core to its 2.8 h")
# an auto-zone search against the full run of the same impact: at most about 1.1 under the
# default budget (zone.cost = 1: no attempt starts once the sphere steps spent and one whole
# run of the last zone reach the full model's; the last attempt's zone is a little larger);
# without it, medium 40 m/s spent 1,500 s in 11 attempts against a projected 1,300 s for the
# full model, unfinished (docs/auto-zone.md); small scale 0.25-0.55
AUTO_OVER_FULL = {"small": 0.55, "medium": 1.1, "paper": 1.1}
TIMING_STEPS = (3, 30)    # warm-up and timed steps of the one-window timing of each model
TIMING_AFTER_CONTACT_S = 2e-4
BENCH = Path(__file__).resolve().parents[3] / "bench" / "results.json"
SWEEPS = ("default", "full")
# the paper pair's seeds: one full paper run costs about 1.3 h of one core, a verdict against
# the full scatter needs two (orchestrator/verdicts.py)
PAPER_SEEDS = {"default": (1,), "full": (1, 2)}
ONLY = ("medium", "paper")


@dataclass(frozen=True)
class Config:
    """One model of the map: the full slab, a fixed DE zone with n_b layers, or the
    automatic zone."""
    scale: str
    velocity: float
    model: str                  # "full" | "coupled"
    zone: str = "box"           # "box" | "auto"
    de_zone: float = None       # m; None: the study's (STUDY_ZONE)
    full_width: bool = None     # None: the study's (STUDY_ZONE)
    layers: int = None          # None: the study's (STUDY_ZONE)
    band_ratio: float = None    # a graded FE mesh's band cells / sphere diameter (None: uniform)
    reinforced: bool = False    # the default bar mesh (docs/reinforcement.md)
    fe_material: str = "elastic"  # or "damage" (docs/fe-damage.md)

    @property
    def name(self):
        return self.layout + ("-damage" if self.fe_material == "damage" else "")

    @property
    def layout(self):
        """The name of its zone and band: where its sensors sit."""
        if self.model == "full":
            return "full"
        d = self.defaults()
        if self.zone == "auto":
            return f"auto-nb{d.layers}"
        graded = "" if self.band_ratio is None else f"-graded-{self.band_ratio:g}d"
        return (f"zone-{d.de_zone:g}m-{'strip' if d.full_width else 'box'}-nb{d.layers}"
                f"{graded}")

    @property
    def group(self):
        """The folder of one impact: scale, velocity, and the reinforced slab apart."""
        return f"{self.scale}-{self.velocity:g}ms" + ("-reinforced" if self.reinforced else "")

    @property
    def folder(self):
        return f"{self.group}/{self.name}"

    def defaults(self):
        """The spec with the study's and the scale's defaults filled in (seed 1)."""
        return self.spec(1)

    def spec(self, seed, steps=None):
        return _spec(self, seed, steps)

    def same_layout_as_full(self):
        """Its sensors sit where the full model's own ones do (the study's zone and band)."""
        if self.model == "full":
            return True
        if self.zone == "auto":
            return False
        d, f = self.defaults(), replace(self, model="full").defaults()
        key = lambda s: (s.de_zone, s.full_width, s.layers, s.band_ratio)
        return key(d) == key(f)


@lru_cache(maxsize=None)
def _spec(config, seed, steps):
    """The SlabSpec of a configuration (cached: the relaxation rule takes 0.15 s per spec;
    callers do not change it)."""
    c = config
    values = dict(scale=c.scale, seed=seed, impactor_speed=c.velocity, steps=steps,
                  reinforced=c.reinforced, zone="box",
                  **dict(zip(("de_zone", "full_width", "layers"), STUDY_ZONE.get(c.scale, ()))))
    if c.model == "coupled":
        values.update({k: v for k, v in dict(
            zone=c.zone, de_zone=c.de_zone, full_width=c.full_width, layers=c.layers,
            band_ratio=c.band_ratio, fe_material=c.fe_material).items() if v is not None})
    return SlabSpec(**{k: v for k, v in values.items() if v is not None})


@dataclass(frozen=True)
class Planned:
    config: Config
    seed: int
    steps: int = None           # None: the scale's
    when: str = None            # the folder of an automatic-zone run that must end clean
                                # first (None: always)
    chosen: bool = False        # paper scale: the configuration is chosen by the medium map

    @property
    def folder(self):
        return f"{self.config.folder}/seed-{self.seed}"

    def spec(self):
        return self.config.spec(self.seed, self.steps)


def paper_steps(dt, velocity, gap=0.002):
    """Steps for PAPER_WINDOW_S after contact (after the impactor's fall of `gap`), in
    hundreds, 1 % to spare for a packing whose critical step is a little shorter."""
    return int(math.ceil(1.01 * (PAPER_WINDOW_S + gap / velocity) / dt / 100.0) * 100)


def plan(sweep="default", velocities=None, only=None, scale="medium", steps=None,
         seeds=SEEDS, paper_config=None, bench=None, paper_seeds=None):
    """The study's runs, in the order they run. scale, steps: the medium part's (a smaller
    scale and a few steps only to test the machinery); paper_config: the configuration the
    medium map chose (None: the paper scale's default zone until the map is made); bench:
    the recorded benchmark (load_bench), for the paper pair's steps; paper_seeds: the paper
    pair's (None: PAPER_SEEDS of the sweep)."""
    if sweep not in SWEEPS:
        raise ValueError(f"study: --sweep must be one of {', '.join(SWEEPS)}, got {sweep!r}")
    if only not in (None,) + ONLY:
        raise ValueError(f"study: --only must be one of {', '.join(ONLY)}, got {only!r}")
    if velocities is None:
        velocities = VELOCITIES if sweep == "full" else DEFAULT_VELOCITIES
    check_velocities(velocities)
    runs = []
    if only in (None, "medium"):
        for v in velocities:
            runs += _medium(sweep, scale, float(v), steps, list(seeds))
        if sweep == "full":
            for v in velocities:
                runs += _reinforced(scale, float(v), steps, list(seeds))
    if only in (None, "paper"):
        runs += _paper(paper_seeds or PAPER_SEEDS[sweep], paper_config, bench)
    return runs


def check_velocities(velocities):
    if not velocities:
        raise ValueError("study: no velocity given")
    for v in velocities:
        if float(v) not in VELOCITIES:
            raise ValueError(f"study: velocity {v!r} m/s is not one of the study's "
                             f"({', '.join(f'{x:g}' for x in VELOCITIES)} m/s)")


def _medium(sweep, scale, v, steps, seeds):
    full = Config(scale, v, "full")
    default = Config(scale, v, "coupled")
    auto = Config(scale, v, "coupled", zone="auto")
    everything = sweep == "full"
    runs = [Planned(default, s, steps) for s in (seeds if everything else seeds[:1])]
    runs.append(Planned(replace(default, band_ratio=GRADED_BAND), seeds[0], steps))
    if everything or v == SWEEP_VELOCITY:
        for de_zone, full_width in ((None, None), (LARGER_ZONE[scale], True),
                                    (SMALL_BOX, False)):
            for nb in SWEEP_LAYERS:
                c = Config(scale, v, "coupled", de_zone=de_zone, full_width=full_width,
                           layers=nb)
                if c.name != default.name:
                    runs.append(Planned(c, seeds[0], steps))
    # the FE that cracks (docs/fe-damage.md): the small box, n_b 1, with its elastic twin where
    # the sweep has not got it, and the default zone where the sweep's velocity is not (the
    # budget: 10 m/s leaves the elastic FE below ft nearly everywhere)
    box = Config(scale, v, "coupled", de_zone=SMALL_BOX, full_width=False, layers=1)
    swept = everything or v == SWEEP_VELOCITY
    twins = [replace(box, fe_material="damage")] + ([] if swept else [box])
    if everything or v != SWEEP_VELOCITY:
        twins.insert(0, replace(default, fe_material="damage"))
    for c in twins:
        runs += [Planned(c, s, steps) for s in (seeds if everything else seeds[:1])]
    runs.append(Planned(auto, seeds[0], steps))
    when = None if everything else f"{auto.folder}/seed-{seeds[0]}"
    runs += [Planned(auto, s, steps, when) for s in seeds[1:]]
    # the full members last: they carry the sensors of every coupled zone of the impact
    runs += [Planned(full, s, steps) for s in seeds]
    return runs


def confirmations(runs, configs):
    """The runs that confirm a fixed zone found to qualify on one seed (`configs`): the same
    configuration on the other seeds of its impact's full ensemble, those not planned yet. One
    packing is one sample of the coupled model's scatter too."""
    planned = {(r.config, r.seed) for r in runs}
    out = []
    for c in configs:
        first = next(r for r in runs if r.config == c)
        seeds = sorted({r.seed for r in runs
                        if r.config.model == "full" and r.config.group == c.group})
        out += [Planned(c, s, first.steps) for s in seeds if (c, s) not in planned]
    return out


def _reinforced(scale, v, steps, seeds):
    """The reinforced slab at `v`: the default zone and the automatic one on every seed, then
    the full ensemble."""
    default = Config(scale, v, "coupled", reinforced=True)
    auto = replace(default, zone="auto")
    full = Config(scale, v, "full", reinforced=True)
    return ([Planned(default, s, steps) for s in seeds] + [Planned(auto, s, steps) for s in seeds]
            + [Planned(full, s, steps) for s in seeds])


def _paper(seeds, config, bench):
    b = bench if bench is not None else load_bench()
    chosen = config is None
    coupled = config if config is not None else Config("paper", max(VELOCITIES), "coupled")
    coupled = replace(coupled, scale="paper")
    n = paper_steps(b["paper"]["full"]["dt"], coupled.velocity)
    return ([Planned(coupled, s, n, chosen=chosen) for s in seeds]
            + [Planned(Config("paper", coupled.velocity, "full"), s, n) for s in seeds])


# --- costs -------------------------------------------------------------------------------------
def load_bench(path=None):
    """The recorded benchmark's per-scale figures (bench/results.json)."""
    path = Path(path or BENCH)
    try:
        data = json.loads(path.read_text())
        raw = data["raw"]["scales"]
        return {s: {m: dict(f[m], n_fe_nodes=raw[s][m]["n_fe_nodes"],
                            dt=_today_dt(f[m]["dt"], raw[s][m].get("dt_safety", STEPS_SAFETY)))
                    for m in ("full", "coupled")} for s, f in data["per_scale"].items()}
    except (OSError, ValueError, KeyError) as e:
        raise ValueError(f"study: the recorded benchmark {path} is unreadable ({e}): run "
                         f"`make bench`") from None


def _today_dt(dt, safety):
    """The benchmark's step `dt`, taken at dt_safety `safety` (benchmarks before the field was
    recorded: the old default, STEPS_SAFETY), at today's default dt_safety."""
    return dt * SlabSpec.dt_safety / safety


def counts(spec, full_spheres):
    """Estimated (spheres, bridging spheres, FE nodes) of the coupled model of `spec` (a box
    zone), from the share of the slab its zone and band cover; `full_spheres`: the full model's
    count (slab and impactor)."""
    from cases.slab.zone import slab_grid
    g = slab_grid(spec)
    nx, ny, nz = g.n
    cells = [round(w / g.h) for w in g.width[:2]]
    band = [min(c + 2 * spec.layers * g.band_h / g.h, n) for c, n in zip(cells, (nx, ny))]
    slab_v, imp_v = SLAB[0] * SLAB[1] * SLAB[2], spec.impactor_side ** 3
    per_v = full_spheres / (slab_v + imp_v)
    zone_share = band[0] * band[1] / (nx * ny)
    band_share = zone_share - cells[0] * cells[1] / (nx * ny)
    spheres = per_v * (zone_share * slab_v + imp_v)
    inner = [max(c - 1, 0) for c in cells]
    if cells[1] >= ny:      # a full-width strip: no node inside it across the whole width
        inner[1] = ny + 1
    nodes = (nx + 1) * (ny + 1) * (nz + 1) - inner[0] * inner[1] * (nz + 1)
    return spheres, per_v * band_share * slab_v, nodes


def step_cost(spec, model, bench):
    """Projected CPU seconds per step of `model` for `spec` (box zones; auto: see run_cost)."""
    b = bench[spec.scale]
    f, c = b["full"], b["coupled"]
    # the impact window's cost: a run is in contact from its first 1-4 % of steps on
    step = lambda m: m["impact_step_s"] or m["step_s"]
    if model == "full":
        return step(f)
    split = c["split_s"]
    per_sphere = (step(c) - split["coupling"] - split["fe"]) / c["n_spheres"]
    per_bridging = c["split_s"]["coupling"] / c["n_bridging_spheres"]
    per_node = c["split_s"]["fe"] / c["n_fe_nodes"]
    spheres, bridging, nodes = counts(spec, f["n_spheres"])
    return per_sphere * spheres + per_bridging * bridging + per_node * nodes


def run_cost(run, bench):
    """Projected seconds of a planned run: its steps and its build."""
    spec = run.spec()
    b = bench[spec.scale]
    full = b["full"]["build_s"] + spec.steps * step_cost(spec, "full", bench)
    if run.config.model == "full":
        return full
    if run.config.zone == "auto":
        return AUTO_OVER_FULL[spec.scale] * full
    return b["coupled"]["build_s"] + spec.steps * step_cost(spec, "coupled", bench)


def timing_cost(runs, bench):
    """The one-window timing of each distinct model (seed 1 of each configuration)."""
    total = 0.0
    for r in timed(runs):
        spec = r.spec()
        dt = bench[spec.scale]["full"]["dt"]
        n = sum(TIMING_STEPS) + advance_steps(spec, dt)
        model = "full" if r.config.model == "full" else "coupled"
        total += bench[spec.scale][model]["build_s"] + n * step_cost(
            replace(spec, zone="box"), model, bench)
    return total


def advance_steps(spec, dt):
    """Steps before the timed window: the impactor's fall and TIMING_AFTER_CONTACT_S of
    impact (paper scale: none, the window right after the build, as `make bench` does)."""
    if spec.scale == "paper":
        return 0
    return int(math.ceil((spec.impactor_gap / spec.impactor_speed + TIMING_AFTER_CONTACT_S)
                         / dt))


def timed(runs):
    """The runs whose model is timed: the first seed of each configuration."""
    seen, out = set(), []
    for r in runs:
        if r.config not in seen and r.when is None:
            seen.add(r.config)
            out.append(r)
    return out


# --- what is done ------------------------------------------------------------------------------
def spec_key(spec):
    """A slab description as compared for reuse: every field but those that change no result;
    a field a recorded description lacks (added since) counts at its declared default."""
    from orchestrator.run.inputs import IGNORED, declared_defaults
    data = {**declared_defaults(SlabSpec), **(spec if isinstance(spec, dict) else asdict(spec))}
    return json.dumps({k: v for k, v in sorted(data.items()) if k not in IGNORED},
                      sort_keys=True, default=str)


def read_summary(folder):
    path = Path(folder) / "summary.json"
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"study: {path}: unreadable ({e})") from None


def complete(folder, run):
    """The run's summary if `folder` holds it finished with the same description (an
    automatic zone that reached its limit is finished too), else None."""
    s = read_summary(folder)
    if s is None or s.get("model") != run.config.model or "spec" not in s:
        return None
    if spec_key(s["spec"]) != spec_key(run.spec()):
        return None
    if s.get("zone_outcome") == "limit" and "n_spheres" not in s:
        return s
    folder = Path(folder)
    if not all((folder / n).is_file() for n in ("sensors.csv", "damage.npz")):
        return None
    return s


def ensemble_index(folders):
    """{(model, spec_key): run folder} of the finished slab runs in `folders` (run folders, or
    folders holding them up to three levels down, e.g. results/slab-medium of `make
    validate`); every ensemble (the seed-N folders of one parent) must be of one kind."""
    from cases.slab.compare import SAME
    from orchestrator.ensemble import check_same_kind
    index = {}
    for top in map(Path, folders):
        if not top.is_dir():
            raise ValueError(f"study: --reuse-ensembles {top}: no such folder")
        found = sorted({p.parent for pattern in ("summary.json", "*/summary.json",
                                                 "*/*/summary.json", "*/*/*/summary.json")
                        for p in top.glob(pattern)})
        if not found:
            raise ValueError(f"study: --reuse-ensembles {top}: no slab run in it (no "
                             f"summary.json down to three levels)")
        parents = {}
        for folder in found:
            s = read_summary(folder)
            if "spec" not in s or "model" not in s:
                continue
            parents.setdefault(folder.parent, {})[str(folder)] = s
            if s.get("zone_outcome") != "limit" or "n_spheres" in s:
                if not all((folder / n).is_file() for n in ("sensors.csv", "damage.npz")):
                    continue
            index.setdefault((s["model"], spec_key(s["spec"])), folder)
        for members in parents.values():
            if len(members) > 1:
                try:
                    for keys in (("scale",), SAME + ("model",)):    # the scale named first
                        check_same_kind({f: {k: s["spec"].get(k, s.get(k)) for k in keys}
                                         for f, s in members.items()})
                except ValueError as e:
                    raise ValueError(f"study: --reuse-ensembles: an ensemble of mixed kinds: "
                                     f"{e}") from None
    return index


def where(run, out, index):
    """(folder, summary) of the finished run: in the study's folder `out`, else among the
    reused ensembles (`index`, ensemble_index); (the study's folder for it, None) if not."""
    own = Path(out) / run.folder
    s = complete(own, run)
    if s is not None:
        return own, s
    other = index.get((run.config.model, spec_key(run.spec())))
    if other is not None:
        return other, complete(other, run)
    return own, None

