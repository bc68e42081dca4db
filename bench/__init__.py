"""Benchmarks of the slab models against the performance goals: `python -m bench`."""
import os

# as `python3 -m cli` runs (cli/__main__.py): numpy's OpenBLAS on one thread; its threads
# made a batch of 3 × 3 inverses 6 × slower beside another run, and the timings are of what
# the command line runs
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
