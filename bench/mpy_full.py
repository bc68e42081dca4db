"""The full slab on YADE's MPI (yade.mpy) against one process: wall ms per step of the run
loop's step, each configuration in its own process(es), one after the other (docs/mpi.md).

    python3 -m bench.mpy_full --scale small --steps 200 [--out FILE.json]

Configurations: one process on 1 and on 2 OpenMP threads; `--mpi 2` (rank 0 + 1 worker) and
`--mpi 3` (rank 0 + 2 workers), one thread per rank. Run it on quiet cores: wall time.
"""
import argparse
import json
import os
import subprocess
import sys
from time import perf_counter

CONFIGS = (("1 process, 1 thread", 1, 0), ("1 process, 2 threads", 2, 0),
           ("mpi 2 (rank 0 + 1 worker)", 1, 2), ("mpi 3 (rank 0 + 2 workers)", 1, 3))
WARMUP = 20


def measure(scale, steps, ranks):
    """Build the full slab (over `ranks` ranks, or one process) and time `steps` steps after
    WARMUP; rank 0 returns the figures, the workers serve and return None."""
    from yade_side import import_yade
    import_yade()
    if ranks:
        from mpi4py import MPI
        from yade_side.distributed import release_workers_at_exit, serve
        if MPI.COMM_WORLD.rank > 0:
            serve()
            return None
        release_workers_at_exit()
    from cases.slab import SlabModel, SlabSpec
    t0 = perf_counter()
    m = SlabModel(SlabSpec(scale=scale, mpi=ranks), "full")
    build = perf_counter() - t0
    for _ in range(WARMUP):
        m.step()
    t0 = perf_counter()
    for _ in range(steps):
        m.step()
    return {"spheres": m.sphere_count(), "build_s": build,
            "ms_per_step": 1e3 * (perf_counter() - t0) / steps}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scale", default="small", choices=("small", "medium", "paper"))
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--out", help="JSON file for the table")
    p.add_argument("--measure", nargs=2, type=int, metavar=("THREADS", "RANKS"),
                   help=argparse.SUPPRESS)      # one configuration, in its own process(es)
    a = p.parse_args()
    if a.measure:
        r = measure(a.scale, a.steps, a.measure[1])
        if r is not None:
            print(json.dumps(r), flush=True)
        return
    rows = []
    for name, threads, ranks in CONFIGS:
        env = dict(os.environ, OMP_NUM_THREADS=str(threads), OMPI_ALLOW_RUN_AS_ROOT="1",
                   OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        cmd = [sys.executable, "-m", "bench.mpy_full", "--scale", a.scale, "--steps",
               str(a.steps), "--measure", str(threads), str(ranks)]
        if ranks:
            cmd = ["mpiexec", "--oversubscribe", "-n", str(ranks)] + cmd
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
        row = {"config": name, "threads": threads, "ranks": ranks,
               **json.loads(out.strip().splitlines()[-1])}
        rows.append(row)
        print(f"{a.scale}: {name}: {row['ms_per_step']:.2f} ms/step "
              f"({rows[0]['ms_per_step'] / row['ms_per_step']:.2f} x one thread), "
              f"{row['spheres']} spheres, build {row['build_s']:.1f} s", flush=True)
    if a.out:
        from common.files import write_text
        write_text(a.out, json.dumps({"scale": a.scale, "steps": a.steps, "warmup": WARMUP,
                                      "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
