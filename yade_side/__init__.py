"""YADE partner: the discrete-element side, embedded in the orchestrator's process.

YADE is imported from Debian's build (`/usr/lib/x86_64-linux-gnu/yade-double/py`), whose
`dist-packages/yade` link is dangling. Knows nothing of the FE side.
"""
import contextlib
import io
import os
import sys

YADE_PY = "/usr/lib/x86_64-linux-gnu/yade-double/py"


def import_yade(threads=None):
    """Import YADE and return the `yade` module.

    `threads` sets OMP_NUM_THREADS, which libgomp reads once, so it only counts on the
    first import in a process; default: the environment's value, else every core this process
    may use. Only one thread gives bit-identical results: YADE's interaction loop hands out
    its contacts to threads as they come (OpenMP schedule(guided)), so several threads sum
    the forces in a varying order (docs/reproducibility.md).
    """
    if "yade" not in sys.modules:
        if threads is not None:
            os.environ["OMP_NUM_THREADS"] = str(int(threads))
        os.environ.setdefault("OMP_NUM_THREADS", str(cores()))
        if not os.path.isdir(YADE_PY):
            raise ImportError(f"YADE not found at {YADE_PY}: run `make setup` (Debian package yade)")
        if YADE_PY not in sys.path:
            sys.path.insert(0, YADE_PY)
        with contextlib.redirect_stdout(io.StringIO()):     # its banner, "Using python version"
            import yade  # noqa: F401
    return sys.modules["yade"]


def cores():
    """The cores this process may run on (a batch scheduler's allocation, not the machine's)."""
    return len(os.sched_getaffinity(0))


def yade_threads():
    """The OpenMP threads YADE runs on in this process (after import_yade)."""
    return int(os.environ.get("OMP_NUM_THREADS", "1"))
