"""The runs of the study "where coupling pays" (docs/where-coupling-pays.md): for each impact,
the full ensemble and the coupled zones of the map on the same packing seeds, as many as the
yardstick (cases.slab.judge) needs to judge, in which folders, at what projected cost, and
which are already done.

Every coupled run has the FE damage law (docs/fe-damage.md) and the slab's defaults (r = ρ,
one bridging layer). Its zones (ZONES): the 0.5 m box, the grown zone (the default, which
starts from that box), and in `--sweep full` the 1.0 m box too (the ceiling at 40 m/s).
The default plan: medium scale, 10 and 40 m/s, seeds 1-4, the full model, the 0.5 m box and
the grown zone (within BUDGET_S of one quiet core, projected). `--sweep full`: 10, 20 and 40 m/s, the 1.0 m
box, the reinforced slab (the two boxes), and at paper scale, at each velocity, the zone the medium map
chooses (the one that qualifies with the largest speed-up, else the grown zone) on seeds
1-3.

Costs are projections from the recorded benchmark (bench/results.json, `make bench`: CPU time
per step of each model in the impact window, one thread): per step of a coupled model,
YADE's cost per sphere (incl. output) in the benchmark's coupled model × spheres + the
coupling's per bridging sphere × bridging spheres + the FE's per node × nodes, with the counts
of each zone estimated from its share of the slab (within 2 % of the benchmark's models). A
grown zone is projected as its start box: a lower bound (its conversions add spheres and
builds)."""
import json
import math
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from pathlib import Path

from cases.slab.scales import SLAB, STEPS_SAFETY
from cases.slab.spec import SlabSpec

VELOCITIES = (10.0, 20.0, 40.0)          # m/s, the study's
DEFAULT_VELOCITIES = (10.0, 40.0)        # the default plan's: the budget
# the members the yardstick's test needs, as the yardstick issue expects them: fewer cannot
# judge the deflection peaks (docs/slab.md, "How a comparison is judged")
SEEDS = {"small": (1, 2, 3, 4, 5, 6), "medium": (1, 2, 3, 4), "paper": (1, 2, 3)}
MIN_SEEDS = 2             # judge.check_members: two same-seed pairs
SMALL_BOX, LARGE_BOX = 0.5, 1.0     # m, the fixed square boxes of the map
# the coupled zones of each plan: (zone, box side); the grown zone starts from the scale's box
ZONES = {"default": (("box", SMALL_BOX), ("grow", None)),
         "full": (("box", SMALL_BOX), ("box", LARGE_BOX), ("grow", None))}
# the reinforced slab's: a grown zone does not carry the bars' state (cases.slab.grow)
REINFORCED_ZONES = (("box", SMALL_BOX), ("box", LARGE_BOX))
FE_MATERIAL = "damage"
# the map's windows (steps at the default dt_safety) where the scale's default window ends
# before the event (docs/where-coupling-pays.md: the full members' ends); None: the default
STEPS = {("medium", 10.0): 3200, ("medium", 20.0): 5480, ("medium", 40.0): 5480,
         ("paper", 10.0): 5760,
         # 12 ms as at medium scale (not measured at paper scale: a full member is hours)
         ("paper", 20.0): 8640, ("paper", 40.0): 8640}
BUDGET_S = 3 * 3600.0     # one core: the default plan fits it (its test)
SWEEPS = ("default", "full")
PAPER_SEEDS = {"default": (), "full": SEEDS["paper"]}
ONLY = ("medium", "paper")
TIMING_STEPS = (3, 30)    # warm-up and timed steps of the one-window timing of each model
TIMING_AFTER_CONTACT_S = 2e-4
BENCH = Path(__file__).resolve().parents[3] / "bench" / "results.json"


@dataclass(frozen=True)
class Config:
    """One model of the map: the full slab, a fixed box, or the zone grown during the run."""
    scale: str
    velocity: float
    model: str                  # "full" | "coupled"
    zone: str = "grow"          # the coupled model's: "box" | "grow"
    de_zone: float = None       # a box's side (m); grow: None (it starts from the scale's box)
    reinforced: bool = False    # the default bar mesh (docs/reinforcement.md)

    @property
    def name(self):
        if self.model == "full":
            return "full"
        return "grown" if self.zone == "grow" else f"box-{self.de_zone:g}m"

    @property
    def group(self):
        """The folder of one impact: scale, velocity, and the reinforced slab apart."""
        return f"{self.scale}-{self.velocity:g}ms" + ("-reinforced" if self.reinforced else "")

    @property
    def folder(self):
        return f"{self.group}/{self.name}"

    def spec(self, seed, steps=None):
        return _spec(self, seed, steps)


@lru_cache(maxsize=None)
def _spec(c, seed, steps):
    """The SlabSpec of a configuration as `slab` records it (cached: callers do not change
    it)."""
    values = dict(scale=c.scale, seed=seed, impactor_speed=c.velocity,
                  steps=steps or STEPS.get((c.scale, c.velocity)), reinforced=c.reinforced,
                  zone="box")
    if c.model == "coupled":
        values.update(zone=c.zone, de_zone=c.de_zone, fe_material=FE_MATERIAL)
    return SlabSpec(**{k: v for k, v in values.items() if v is not None})


@dataclass(frozen=True)
class Planned:
    config: Config
    seed: int
    steps: int = None           # None: the impact's window (STEPS, else the scale's)

    @property
    def folder(self):
        return f"{self.config.folder}/seed-{self.seed}"

    def spec(self):
        return self.config.spec(self.seed, self.steps)


def plan(sweep="default", velocities=None, only=None, scale="medium", steps=None,
         seeds=None, paper_choice=None, paper_seeds=None):
    """The study's runs, in the order they run. scale, steps, seeds: the medium part's (a
    smaller scale and a few steps only to test the machinery; seeds: SEEDS of the scale);
    paper_choice: {velocity: Config} the medium map chose (missing: the grown zone);
    paper_seeds: the paper part's (None: PAPER_SEEDS of the sweep). Raises ValueError (one
    line) on a bad choice."""
    if sweep not in SWEEPS:
        raise ValueError(f"study: --sweep must be one of {', '.join(SWEEPS)}, got {sweep!r}")
    if only not in (None,) + ONLY:
        raise ValueError(f"study: --only must be one of {', '.join(ONLY)}, got {only!r}")
    if velocities is None:
        velocities = VELOCITIES if sweep == "full" else DEFAULT_VELOCITIES
    check_velocities(velocities)
    seeds = tuple(seeds or SEEDS[scale])
    paper_seeds = PAPER_SEEDS[sweep] if paper_seeds is None else tuple(paper_seeds)
    check_seeds("--seeds", seeds)
    if paper_seeds:
        check_seeds("--paper-seeds", paper_seeds)
    zones = ZONES[sweep]
    runs = []
    if only in (None, "medium"):
        for v in map(float, velocities):
            runs += impact(Config(scale, v, "full"), zones, seeds, steps)
        if sweep == "full":
            for v in map(float, velocities):
                runs += impact(Config(scale, v, "full", reinforced=True), REINFORCED_ZONES,
                               seeds, steps)
    if only in (None, "paper") and paper_seeds:
        for v in map(float, velocities):
            chosen = (paper_choice or {}).get(v)
            zone = ((chosen.zone, chosen.de_zone) if chosen is not None else ("grow", None),)
            runs += impact(Config("paper", v, "full"), zone, paper_seeds, None)
    return runs


def impact(full, zones, seeds, steps):
    """The runs of one impact: its full ensemble, then each coupled zone on the same seeds."""
    configs = [full] + [Config(full.scale, full.velocity, "coupled", zone=z, de_zone=side,
                               reinforced=full.reinforced) for z, side in zones]
    return [Planned(c, s, steps) for c in configs for s in seeds]


def check_velocities(velocities):
    if not velocities:
        raise ValueError("study: no velocity given")
    for v in velocities:
        if float(v) not in VELOCITIES:
            raise ValueError(f"study: velocity {v!r} m/s is not one of the study's "
                             f"({', '.join(f'{x:g}' for x in VELOCITIES)} m/s)")


def check_seeds(option, seeds):
    if len(set(seeds)) < MIN_SEEDS or len(set(seeds)) != len(seeds):
        raise ValueError(f"study: {option} {','.join(map(str, seeds))}: the yardstick needs "
                         f"{MIN_SEEDS} or more distinct seeds (same-seed pairs)")


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


def _as_box(spec):
    """A grown zone's spec as its start box (the projection's lower bound)."""
    return spec if spec.zone == "box" else replace(spec, zone="box")


def step_cost(spec, model, bench):
    """Projected CPU seconds per step of `model` for `spec` (a grown zone: its start box)."""
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
    spheres, bridging, nodes = counts(_as_box(spec), f["n_spheres"])
    return per_sphere * spheres + per_bridging * bridging + per_node * nodes


def run_cost(run, bench):
    """Projected seconds of a planned run: its steps and its build."""
    spec = run.spec()
    model = run.config.model
    b = bench[spec.scale][model]
    return b["build_s"] + window_steps(spec, bench) * step_cost(spec, model, bench)


def window_steps(spec, bench):
    """The run's steps: its own, else the scale's default window at the benchmark's dt."""
    if spec.steps:
        return spec.steps
    from cases.slab.scales import duration
    return int(math.ceil(duration(spec.scale, spec.impactor_speed)
                         / bench[spec.scale]["full"]["dt"]))


def timing_cost(runs, bench):
    """The one-window timing of each distinct model (the first seed of each configuration)."""
    total = 0.0
    for r in timed(runs):
        spec = r.spec()
        dt = bench[spec.scale]["full"]["dt"]
        n = sum(TIMING_STEPS) + advance_steps(spec, dt)
        model = r.config.model
        total += bench[spec.scale][model]["build_s"] + n * step_cost(spec, model, bench)
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
        if r.config not in seen:
            seen.add(r.config)
            out.append(r)
    return out


# --- what is done ------------------------------------------------------------------------------
def spec_key(spec, model):
    """A slab description as compared for reuse by a `model` run: every field but those that
    change no result, and those that cannot act on that model (the full model's relaxation,
    FE modulus, ...: cases.slab.spec.NEEDS); a field a recorded description lacks (added
    since) counts at its declared default."""
    from orchestrator.run.inputs import IGNORED, declared_defaults
    from cases.slab.spec import inert_fields
    data = {**declared_defaults(SlabSpec), **(spec if isinstance(spec, dict) else asdict(spec))}
    left_out = IGNORED | inert_fields(data, model)
    return json.dumps({k: v for k, v in sorted(data.items()) if k not in left_out},
                      sort_keys=True, default=str)


def read_summary(folder):
    path = Path(folder) / "summary.json"
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"study: {path}: unreadable ({e})") from None


def finished(folder, summary):
    """A run whose zone reached its limit is finished with its summary alone; any other needs
    its sensors and damage."""
    if summary.get("zone_outcome") == "limit" and "n_spheres" not in summary:
        return True
    return all((Path(folder) / n).is_file() for n in ("sensors.csv", "damage.npz"))


def complete(folder, run):
    """The run's summary if `folder` holds it finished with the same description, else None."""
    s = read_summary(folder)
    if s is None or s.get("model") != run.config.model or "spec" not in s:
        return None
    model = run.config.model
    if spec_key(s["spec"], model) != spec_key(run.spec(), model) or not finished(folder, s):
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
            if folder.name.startswith("seed-"):
                parents.setdefault(folder.parent, {})[str(folder)] = s
            if finished(folder, s):
                index.setdefault((s["model"], spec_key(s["spec"], s["model"])), folder)
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
    other = index.get((run.config.model, spec_key(run.spec(), run.config.model)))
    if other is not None:
        return other, complete(other, run)
    return own, None
