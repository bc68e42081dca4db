"""The damage law's C loops (damage_kernels.c): compiled on first use by the C compiler that the
FE forms already need (FFCx compiles them at run time too), kept in the project's cache under a
name made from the source and the flags, called through ctypes on numpy arrays whose type and
layout ctypes checks."""
import ctypes
import functools
import hashlib
import os
import shlex
import subprocess
from pathlib import Path

import numpy as np

from common.files import atomic, cache_folder

SOURCE = Path(__file__).with_name("damage_kernels.c")
# No -march=native and no fused multiply-add: the same digits on any machine with this
# compiler and C library (the Debian stack, the image included).
FLAGS = ("-O2", "-std=c99", "-fPIC", "-shared", "-ffp-contract=off", "-fno-math-errno")

_D = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
_I = np.ctypeslib.ndpointer(np.int64, flags="C_CONTIGUOUS")
_N, _F = ctypes.c_int64, ctypes.c_double
SIGNATURES = {
    "positive_part": (_N, _D, _D),
    "tension_strain": (_N, _D, _D, _F, _F, _D),
    "compression_strain": (_N, _D, _F, _F, _D),
    "damage": (_N, _D, _D, _F, _D),
    "screen": (_N, _D, _D, _D, _F, _F, _F, _F, _D, _I,
               np.ctypeslib.ndpointer(np.int8, flags="C_CONTIGUOUS")),
    "grow_damage": (_N, _I, _D, _D, _D, _D, _F, _D, _D, _D, _D),
    "cell_strains": (_N, _N, _I, _D, _D, _D),
    "split_cells": (_N, _N, _I, _I, _D, _D, _F, _F, _D, _D, _D),
    "dissipation": (_N, _N, _N, _I, _I, _D, _D, _D, _D, _D, _D, _D, _D, _D, _D),
    "lost_forces": (_N, _N, _I, _I, _D, _D, _D, _D, _D, _D, _I, _D, _I, _D, _D),
}

RETURNS = {"dissipation": ctypes.c_double, "screen": ctypes.c_int64}


@functools.cache
def library():
    """The compiled kernels (ctypes library, argument types set); RuntimeError (one line) if
    the compiler fails."""
    compiler = shlex.split(os.environ.get("CC") or "cc")
    source = SOURCE.read_bytes()
    key = hashlib.sha256(source + " ".join(compiler + list(FLAGS)).encode()).hexdigest()[:16]
    path = cache_folder("kernels") / f"damage_kernels-{key}.so"
    if not path.exists():
        with atomic(path) as tmp:
            done = subprocess.run([*compiler, *FLAGS, "-o", str(tmp), str(SOURCE), "-lm"],
                                  capture_output=True, text=True)
            if done.returncode:
                lines = done.stderr.strip().splitlines() or ["no message"]
                first = next((l for l in lines if "error" in l), lines[0])
                raise RuntimeError(f"compiling {SOURCE.name} with {' '.join(compiler)} failed: "
                                   f"{first}")
    lib = ctypes.CDLL(str(path))
    for name, args in SIGNATURES.items():
        getattr(lib, name).argtypes = args
        getattr(lib, name).restype = RETURNS.get(name)
    return lib


def contiguous(v):
    """v as a C-contiguous float64 (6, n) array (a view when it already is)."""
    return np.ascontiguousarray(v, dtype=np.float64)
