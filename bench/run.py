"""`make bench`: the slab models against the performance goals, in one run on one machine.

Each model is built and timed in its own subprocess (bench.worker): peak memory is that
process's ru_maxrss, and OMP_NUM_THREADS (read once by libgomp) is set per process. Writes
bench/results.json and docs/benchmarks.md (both atomically); `--quick` measures the small and
medium scales with fewer steps and writes bench/results-quick.json and bench/benchmarks-quick.md.
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

from bench.report import derive, markdown
from common.files import write_json, write_text

ROOT = Path(__file__).resolve().parent.parent
# (warm-up steps, timed steps) per scale
PLANS = {
    "full": {"small": (20, 200), "medium": (20, 200), "paper": (10, 200)},
    "quick": {"small": (5, 60), "medium": (5, 40)},
}
IMPACT_AFTER_S = 5e-4     # the second window: 0.5 ms into the run, the slab cracking under the impactor
THREADS = (1, 2)
TIMED_AFTER_CONVERSION = 100    # steps of the grown model timed after a conversion
# at paper scale, a late conversion too: the ring around a 1.5 m start zone (69k spheres; the
# budget off, zone.cost 2: the bench times the conversion, not whether it pays)
LARGE_ZONE = {"zone_start": 1.5, "zone_cost": 2.0}
TIMED_AFTER_LARGE = 40
TIMEOUT_S = 1800
# `--quick` fails when the medium coupled step is slower than bench/results.json's by more
REGRESSION = 1.15


def worker(task, threads=1):
    """Run bench.worker on `task` in a fresh process with `threads` OpenMP threads."""
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), PYTHONPATH=str(ROOT))
    label = f"{task['scale']} {task['model']} ({threads} thread{'s' if threads > 1 else ''})"
    print(f"bench: {label} ...", flush=True)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "bench.worker", json.dumps(task)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    if proc.returncode != 0:
        raise RuntimeError(f"bench worker for {label} failed (exit {proc.returncode}):\n"
                           f"{proc.stderr[-3000:]}")
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    print(f"bench: {label}: {1e3 * result['timing']['median_s']:.2f} ms/step "
          f"({result['timing']['clock']}), "
          f"{result['peak_rss_bytes'] / 1e9:.2f} GB, {time.perf_counter() - t0:.0f} s",
          flush=True)
    return result


def measure(plan):
    raw = {"scales": {}, "threads": {}}
    for scale, (warmup, steps) in plan.items():
        base = {"scale": scale, "warmup": warmup, "steps": steps, "impact_after_s": IMPACT_AFTER_S}
        raw["scales"][scale] = {
            "full": worker(dict(base, model="full", output=True)),
            "coupled": worker(dict(base, model="coupled", output=True,
                                   variants=["diagonal", "full"])),
            "coupled_damage": worker(dict(base, model="coupled",
                                          spec={"scale": scale, "fe_material": "damage"})),
            "conversion": worker(dict(base, model="coupled", conversion=True,
                                      steps=min(steps, TIMED_AFTER_CONVERSION))),
        }
        if scale == "paper":
            raw["scales"][scale]["conversion_large"] = worker(dict(
                base, model="coupled", conversion=True, spec=dict(LARGE_ZONE, scale=scale),
                steps=min(steps, TIMED_AFTER_LARGE)))
    # OpenMP threads: the full model (YADE alone) at the largest scale below paper
    below_paper = [s for s in plan if s != "paper"]
    if not below_paper:
        return raw
    scale = below_paper[-1]
    warmup, steps = plan[scale]
    for threads in THREADS:
        result = raw["scales"][scale]["full"] if threads == 1 else worker(
            {"scale": scale, "model": "full", "warmup": warmup, "steps": steps // 2}, threads)
        raw["threads"][str(threads)] = {"scale": scale, "s_per_step": result["timing"]["wall_median_s"],
                                        "n_spheres": result["n_spheres"]}
    return raw


def regression(raw, reference_path):
    """Lines comparing the medium coupled step (CPU time per step, both windows) with the
    reference run's, and whether it is slower by more than REGRESSION; the full model's ratio
    alongside says how much of a change is the machine's."""
    try:
        reference = json.loads(Path(reference_path).read_text())["raw"]["scales"]["medium"]
    except (OSError, ValueError, KeyError) as e:
        return [f"bench: no reference medium figures in {reference_path} ({e})"], False
    now = raw["scales"]["medium"]
    lines, slower = [], False
    for window in ("timing", "timing_impact"):
        ratio = {model: now[model][window]["median_s"] / reference[model][window]["median_s"]
                 for model in ("coupled", "full")}
        slower |= ratio["coupled"] > REGRESSION
        lines.append(f"bench: medium coupled step{' in the impact' if window != 'timing' else ''}"
                     f" {1e3 * now['coupled'][window]['median_s']:.2f} ms = {ratio['coupled']:.3f}"
                     f" x {reference_path.name}'s (full model {ratio['full']:.3f} x)")
    return lines, slower


def machine():
    return {"cpus": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "load_average": os.getloadavg()}


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="small and medium scales, fewer steps (a few minutes); fails if "
                             "the medium coupled step is over 15 %% slower than in "
                             "bench/results.json")
    parser.add_argument("--json", type=Path, help="results file (default: bench/results.json, "
                        "or bench/results-quick.json with --quick)")
    parser.add_argument("--md", type=Path, help="Markdown table (default: docs/benchmarks.md, "
                        "or bench/benchmarks-quick.md with --quick)")
    args = parser.parse_args(argv)
    mode = "quick" if args.quick else "full"
    json_path = args.json or ROOT / ("bench/results-quick.json" if args.quick else "bench/results.json")
    md_path = args.md or ROOT / ("bench/benchmarks-quick.md" if args.quick else "docs/benchmarks.md")
    t0 = time.perf_counter()
    info = {"mode": mode, "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "machine_at_start": machine()}
    raw = measure(PLANS[mode])
    info["machine_at_end"] = machine()
    info["bench_wall_s"] = time.perf_counter() - t0
    results = dict(info, raw=raw, **derive(raw))
    for path in (json_path, md_path):
        if path.exists():
            print(f"bench: replacing {path}")
    write_json(json_path, results)
    write_text(md_path, markdown(results))
    print(f"bench: wrote {json_path} and {md_path} in {info['bench_wall_s'] / 60:.1f} min")
    for goal in results["goals"]:
        print(f"  {'met   ' if goal['met'] else 'MISSED' if goal['met'] is False else 'n/a   '} "
              f"{goal['goal']}: {goal['figure']}")
    if args.quick:
        lines, slower = regression(raw, ROOT / "bench/results.json")
        print("\n".join(lines))
        if slower:
            sys.exit(f"bench: the medium coupled step regressed by more than "
                     f"{REGRESSION - 1:.0%} against bench/results.json")


if __name__ == "__main__":
    main()
