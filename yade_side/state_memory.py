"""Direct numpy access to YADE's body states, verified against YADE's own bulk API.

YADE's `Subdomain.get/setStateValuesFromIds` pass every value through a Python float: with
~5,000 bridging spheres that costs 4–9 ms per step, more than the coupling itself (measured,
docs/benchmarks.md), and no Debian build of YADE 2023.02a offers an array interface, nor can a
C++ plugin be built here (platform notes). So we locate each body's C++ `State` in memory
and the offsets of pos, vel, angVel and ori inside it, then read and write the 13 values of
all bodies with one numpy gather/scatter.

Nothing is assumed blindly: the field offsets are found by writing distinct values to one
body through YADE's API, and the gathered values of every body must equal YADE's API read bit
for bit before the view is used; otherwise `locate` returns None and the caller keeps the API.
The views hold references to the State wrappers, so the C++ objects outlive the view.
"""
import ctypes

import numpy as np

# boost.python instance: PyObject_VAR_HEAD (3 words), dict, weakrefs, holder pointer (word 5),
# then the in-place pointer_holder: vtable, next, shared_ptr<State> (pointer at word 8)
_HOLDER_WORD, _HOLDER_OFFSET, _POINTER_WORD = 5, 48, 8
_SEARCH = 64  # doubles of a State searched for the fields
_WIDTHS = (3, 3, 3, 4)  # pos, vel, angVel, ori (x, y, z, w): the API's order


class SceneReplaced(RuntimeError):
    pass


class StateMemory:
    """Gather/scatter of the 13 API values of a fixed list of bodies. Each call first checks
    that the scene still holds the first body's State (a few µs): after O.load or O.reset the
    view would otherwise read and write States no longer simulated."""

    def __init__(self, omega, first_id, wrappers, index, base, span):
        self._omega, self._first_id = omega, first_id
        self._wrappers = wrappers  # keep the C++ States alive: their addresses stay unique
        self._first_address = state_address(wrappers[0])
        self._index = index        # (n, 13) offsets in doubles from `base`
        self._view = np.ctypeslib.as_array((ctypes.c_double * span).from_address(base))

    def _check(self):
        if state_address(self._omega.bodies[self._first_id].state) != self._first_address:
            raise SceneReplaced("YADE's bodies were replaced (O.load or O.reset) after this body "
                                "set located them in memory: reattach it to the new scene")

    def read(self, out):
        self._check()
        # indices are in range by construction; mode="raise" would buffer `out` (2x slower)
        np.take(self._view, self._index, out=out, mode="clip")

    def write(self, values):
        self._check()
        self._view[self._index] = values


def state_address(wrapper):
    """Address of the C++ State held by a boost.python State wrapper, or None if the wrapper
    does not have the expected layout."""
    words = (ctypes.c_uint64 * 10).from_address(id(wrapper))
    if words[_HOLDER_WORD] != id(wrapper) + _HOLDER_OFFSET or not words[_POINTER_WORD]:
        return None
    return int(words[_POINTER_WORD])


def locate(omega, ids, get, put):
    """A verified StateMemory for the bodies `ids`, or None.

    omega: yade.Omega(); get(ids) / put(ids, values): YADE's bulk API (13 values per body).
    """
    if len(ids) == 0:
        return None
    wrappers = [omega.bodies[i].state for i in ids]
    addresses = [state_address(w) for w in wrappers]
    if None in addresses or any(a % 8 for a in addresses):
        return None
    offsets = _field_offsets(addresses[0], ids[0], get, put)
    if offsets is None:
        return None
    addresses = np.array(addresses, dtype=np.int64)
    base = int(addresses.min())
    span = int(addresses.max() - base) // 8 + _SEARCH
    index = (addresses - base)[:, None] // 8 + offsets[None, :]
    memory = StateMemory(omega, ids[0], wrappers, index, base, span)
    expected = np.array(get(ids), float).reshape(-1, 13)
    got = np.empty_like(expected)
    memory.read(got)
    return memory if np.array_equal(got.view(np.int64), expected.view(np.int64)) else None


def _field_offsets(address, body_id, get, put):
    """Offsets (13,) in doubles of the API's values inside one State: write distinct values
    through the API, find them in memory, restore the body's state."""
    saved = list(get([body_id]))
    probe = 1000.0 + np.arange(13) / 16.0  # exact binary fractions, unlike any state value
    put([body_id], probe.tolist())
    try:
        memory = np.ctypeslib.as_array((ctypes.c_double * _SEARCH).from_address(address)).copy()
    finally:
        put([body_id], saved)
    offsets, start = [], 0
    for width in _WIDTHS:
        field = probe[start:start + width]
        hits = [o for o in range(_SEARCH - width + 1) if np.array_equal(memory[o:o + width], field)]
        if len(hits) != 1:
            return None
        offsets.extend(range(hits[0], hits[0] + width))
        start += width
    return np.array(offsets, dtype=np.int64)
