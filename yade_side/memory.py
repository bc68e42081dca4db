"""YADE's C++ memory, read and written directly by numpy: the body states (pos, vel, angVel,
ori), the CPM links' damage history and named fields of their physics (Fields). The only
module that does so; it refuses a YADE version it was not verified on (VERIFIED), and every
view is verified bit for bit against what YADE's own API reads before it is used.

Body states. 
YADE's `Subdomain.get/setStateValuesFromIds` pass every value through a Python float: with
~5,000 bridging spheres that costs 4–9 ms per step, more than the coupling itself (measured,
docs/benchmarks.md), and no Debian build of YADE 2023.02a offers an array interface, nor can a
C++ plugin be built against Debian's package (no headers). So we locate each body's C++ `State` in memory
and the offsets of pos, vel, angVel and ori inside it, then read and write the 13 values of
all bodies with one numpy gather/scatter.

Nothing is assumed blindly: the field offsets are found by writing distinct values to one
body through YADE's API, and the gathered values of every body must equal YADE's API read bit
for bit before the view is used; otherwise `locate` returns None and the caller keeps the API.
The views hold references to the State wrappers, so the C++ objects outlive the view.
"""
import ctypes

import numpy as np

from yade_side import import_yade

# YADE versions whose memory layouts were verified (tests/test_yade_side.py, test_checkpoint.py)
VERIFIED = ("2023.02a",)

# boost.python instance: PyObject_VAR_HEAD (3 words), dict, weakrefs, holder pointer (word 5),
# then the in-place pointer_holder: vtable, next, shared_ptr<State> (pointer at word 8)
_HOLDER_WORD, _HOLDER_OFFSET, _POINTER_WORD = 5, 48, 8
_STATE_SEARCH = 64  # doubles of a State searched for the fields
_WIDTHS = (3, 3, 3, 4)  # pos, vel, angVel, ori (x, y, z, w): the API's order


class SceneReplaced(RuntimeError):
    pass


class CheckpointError(RuntimeError):
    pass


def yade_version():
    return import_yade().config.version


def verified():
    """True when this YADE's memory layout is one the project verified."""
    return yade_version() in VERIFIED


def check_version(error=RuntimeError):
    if not verified():
        raise error(f"YADE {yade_version()} is not a version whose memory layout was verified "
                    f"({', '.join(VERIFIED)}): direct access to YADE's memory is refused")


class StateMemory:
    """Gather/scatter of the 13 API values of a fixed list of bodies. Each call first checks
    that the scene still holds the first body's State (a few µs), and every FULL_CHECK-th
    call that it still holds every body's: after O.load, O.reset or a body replaced the view
    would otherwise read and write States no longer simulated."""
    FULL_CHECK = 64

    def __init__(self, omega, ids, wrappers, addresses, offsets):
        self._omega, self._ids = omega, list(ids)
        self._wrappers = list(wrappers)   # keep the C++ States alive: addresses stay unique
        self._addresses, self._offsets = list(addresses), offsets
        a = np.array(self._addresses, dtype=np.int64)
        base = int(a.min())
        span = int(a.max() - base) // 8 + _STATE_SEARCH
        self._index = (a - base)[:, None] // 8 + offsets[None, :]  # (n, 13), doubles from base
        self._view = np.ctypeslib.as_array((ctypes.c_double * span).from_address(base))
        self._calls = 0

    def joined(self, other):
        """The view of this memory's bodies then `other`'s (of the same scene), as verified."""
        if not np.array_equal(self._offsets, other._offsets):
            raise ValueError("two State layouts in one scene")
        return StateMemory(self._omega, self._ids + other._ids,
                           self._wrappers + other._wrappers,
                           self._addresses + other._addresses, self._offsets)

    def taken(self, rows):
        """The view of the bodies `rows` of this one."""
        rows = np.asarray(rows, int).tolist()
        pick = lambda values: [values[r] for r in rows]
        return StateMemory(self._omega, pick(self._ids), pick(self._wrappers),
                           pick(self._addresses), self._offsets)

    def _check(self):
        self._calls += 1
        bodies = self._omega.bodies
        checked = (zip(self._ids, self._addresses) if self._calls % self.FULL_CHECK == 0
                   else [(self._ids[0], self._addresses[0])])
        for i, address in checked:
            if i >= len(bodies) or bodies[i] is None or state_address(bodies[i].state) != address:
                raise SceneReplaced("YADE's bodies were replaced (O.load, O.reset or a body "
                                    "erased) after this body set located them in memory: "
                                    "reattach it to the new scene")

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
    if len(ids) == 0 or not verified():
        return None
    wrappers = [omega.bodies[i].state for i in ids]
    addresses = [state_address(w) for w in wrappers]
    if None in addresses or any(a % 8 for a in addresses):
        return None
    offsets = _field_offsets(addresses[0], ids[0], get, put)
    if offsets is None:
        return None
    memory = StateMemory(omega, ids, wrappers, addresses, offsets)
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
        memory = np.ctypeslib.as_array(
            (ctypes.c_double * _STATE_SEARCH).from_address(address)).copy()
    finally:
        put([body_id], saved)
    offsets, start = [], 0
    for width in _WIDTHS:
        field = probe[start:start + width]
        hits = [o for o in range(_STATE_SEARCH - width + 1)
                if np.array_equal(memory[o:o + width], field)]
        if len(hits) != 1:
            return None
        offsets.extend(range(hits[0], hits[0] + width))
        start += width
    return np.array(offsets, dtype=np.int64)


# --- CPM links: the damage history O.save does not keep (yade_side.checkpoint) -----------------
# CpmPhys members after the serialised base, in declaration order: 7 reals, 4 Vector3r
HISTORY = ("omega", "Fn", "sigmaN", "epsN", "relResidualStrength", "kappaD", "epsNPl",
           "sigmaT", "Fs", "epsTPl", "epsT")
WIDTH = 19
_SEARCH = 128  # doubles of a CpmPhys (or a geometry) searched for a field
_REVERIFY = 16  # links on which a found offset is verified again
# where the block lies in the CpmPhys of the verified versions (found on damaged links)
HISTORY_OFFSET = {"2023.02a": 12}


def history_values(phys):
    """The 19 history doubles of a CpmPhys, as Python reads them."""
    values = []
    for name in HISTORY:
        v = getattr(phys, name)
        if isinstance(v, float):
            values.append(v)
        else:                   # a Vector3r: indexed (iterating it costs 8 × as much)
            values.extend((v[0], v[1], v[2]))
    return np.array(values, float)


def histories(phys):
    """history_values of each CpmPhys of `phys`, (n, WIDTH)."""
    return np.array([history_values(p) for p in phys], float).reshape(-1, WIDTH)


class Blocks:
    """Blocks of `width` doubles at `offset` in each of a list of C++ objects (their boost.python
    wrappers), read and written by one numpy gather/scatter (a view from the lowest address to
    the highest; the wrappers are kept, so the C++ objects outlive it). Only while the scene
    holds those objects."""

    def __init__(self, objects, offset, width, columns=None):
        self._objects = list(objects)
        rows, self._view = _object_view(self._objects, offset + width)
        index = rows[:, None] + offset + (np.arange(width) if columns is None
                                          else np.asarray(columns, int))
        # half the memory where the objects lie within 16 GB of each other (the usual heap)
        small = index.size and index.max() < np.iinfo(np.int32).max
        self._index = index.astype(np.int32) if small else index

    def read(self):
        """(objects, columns) doubles: every column of the block, or `columns` of it."""
        return np.take(self._view, self._index)

    def write(self, values, rows=None):
        index = self._index if rows is None else self._index[rows]
        self._view[index] = values


def _object_view(objects, extent):
    """(rows, view): a view of doubles from the lowest address of the C++ objects (their
    wrappers) to `extent` doubles past the highest, and each object's first double in it."""
    addresses = [state_address(o) for o in objects]
    if None in addresses:
        raise CheckpointError("cannot locate a YADE object in memory: unexpected "
                              "boost.python layout")
    addresses = np.array(addresses, np.int64)
    if (addresses % 8).any():
        raise CheckpointError("a YADE object is not 8-byte aligned in memory")
    if not len(addresses):
        return addresses, np.empty(0)
    base = int(addresses.min())
    span = int(addresses.max() - base) // 8 + extent
    return (addresses - base) // 8, np.ctypeslib.as_array(
        (ctypes.c_double * span).from_address(base))


class HistoryBlocks(Blocks):
    """The history blocks (HISTORY) of a list of CpmPhys; with `columns`, those of each."""

    def __init__(self, phys, offset, columns=None):
        super().__init__(phys, offset, WIDTH, columns)


# --- the normal of interaction geometries (ScGeom.normal, a Vector3r), read and written in bulk
NORMAL_WIDTH = 3


def normal_values(geom):
    n = geom.normal
    return np.array((n[0], n[1], n[2]), float)


def normals(geoms):
    """normal_values of each geometry of `geoms`, (n, NORMAL_WIDTH)."""
    return np.array([normal_values(g) for g in geoms], float).reshape(-1, NORMAL_WIDTH)


def find_normal_offset(geoms, sample=None):
    """Offset (in doubles) of `normal` inside the interaction geometries `geoms` (one class),
    found and verified as find_offset finds the CPM history's. CheckpointError if it cannot
    be found."""
    return _locate(geoms, normals, NORMAL_WIDTH, sample, "the geometries' normal")


def same_bits(a, b):
    """Bit-for-bit equality of two float arrays."""
    return np.array_equal(np.asarray(a, float).view(np.int64), np.asarray(b, float).view(np.int64))


def find_offset(links, sample=None):
    """Offset (in doubles) of the history block inside CpmPhys: where every link's memory
    holds exactly the values Python reads (with `sample`, that many links spread over the
    list: the layout is the class's, the same in every link). Links at rest can hold a block
    (mostly zeros) that matches at several places; the offset this YADE version's layout was
    verified at (HISTORY_OFFSET) then decides. Once found on `sample` or more links, the
    offset is the class's for this process: later sampled calls verify it on a few of their
    links (_REVERIFY) and search again only if they disagree; a call without `sample` (a
    checkpoint) verifies every link. CheckpointError if it cannot be found."""
    return history_offset([i.phys for i in links], sample)


def history_offset(phys, sample=None):
    """find_offset of the links whose CpmPhys are `phys`."""
    return _locate(phys, histories, WIDTH, sample, "the CPM history",
                   HISTORY_OFFSET.get(yade_version()))


_found = {}     # field -> its offset, once found on a whole sample in this process


def _locate(objects, values, width, sample, field, known=None):
    """find_offset's search for any field of `width` doubles in the C++ objects `objects`
    (their wrappers, one class), values(objects) (n, width) being what Python reads of it:
    the offsets where the object with the most non-zero values holds them, kept where every
    object (or the sample's) does; `known` decides between several."""
    if not objects:
        return None
    cached = _found.get(field)
    if cached is not None and sample is not None:
        few = objects[::-(-len(objects) // _REVERIFY)]
        if same_bits(Blocks(few, cached, width).read(), values(few)):
            return cached
    whole = sample is None or len(objects) >= sample
    if sample is not None and len(objects) > sample:
        objects = objects[::-(-len(objects) // sample)]
    want = values(objects)
    probe = int(np.argmax(np.count_nonzero(want, axis=1)))   # the first with the most
    address = state_address(objects[probe])
    if address is None:
        raise CheckpointError(f"cannot locate {field} in memory: unexpected boost.python "
                              f"layout")
    memory = np.ctypeslib.as_array((ctypes.c_double * _SEARCH).from_address(address)).copy()
    hits = [o for o in range(_SEARCH - width + 1) if same_bits(memory[o:o + width], want[probe])]
    hits = [o for o in hits if same_bits(Blocks(objects, o, width).read(), want)]
    if len(hits) > 1 and known in hits:
        hits = [known]
    if len(hits) != 1:
        raise CheckpointError(f"{field} found {len(hits)} times in memory (in every object "
                              f"of {len(objects)}): cannot read it in bulk")
    if whole:
        _found[field] = hits[0]
    return hits[0]


# --- named fields of one class's objects (CpmPhys), read and written in bulk ------------------
class Fields:
    """Named fields (doubles, or Vector3r as 3) of C++ objects of one class (their wrappers,
    kept so the objects outlive the view), read and written by one numpy gather/scatter each.
    The offsets are found once per class and process by probing one object (distinct values
    written through its API, found in its memory, the object restored: field_offsets), then
    verified bit for bit against the API on up to SAMPLE of the objects at every use.
    CheckpointError if they cannot be. Needs at least one object."""
    SAMPLE = 64

    def __init__(self, objects, names):
        check_version(CheckpointError)
        self.objects, self.names = list(objects), tuple(names)
        if not self.objects:
            raise ValueError("Fields of no object")
        self._offsets = field_offsets(self.objects[0], self.names)
        self._rows, self._view = _object_view(self.objects, _SEARCH)
        rows = np.arange(0, len(self.objects), max(1, -(-len(self.objects) // self.SAMPLE)))
        for name in self.names:
            api = np.array([_api_value(self.objects[r], name) for r in rows], float)
            if not same_bits(self.read(name)[rows].reshape(api.shape), api):
                raise CheckpointError(f"the field {name} is not where it was found in memory")

    def _index(self, offset, width):
        return self._rows[:, None] + offset + np.arange(width)

    def read(self, name):
        """(n,) or (n, 3) values of the field `name` of every object."""
        offset, width = self._offsets[name]
        out = self.read_block(offset, width)
        return out[:, 0] if width == 1 else out

    def write(self, **values):
        """Write each field name=array ((n,) or (n, 3)) into every object."""
        for name, v in values.items():
            self.write_block(*self._offsets[name], v)

    def read_block(self, offset, width):
        """(n, width) doubles at `offset` (found elsewhere: e.g. history_offset) of every
        object, offset + width within _SEARCH."""
        return self._view[self._index(offset, width)]

    def write_block(self, offset, width, values):
        index = self._index(offset, width)
        self._view[index] = np.asarray(values, float).reshape(index.shape)


_field_found = {}   # (class name, field) -> (offset, width), once probed in this process


def _api_value(obj, name):
    v = getattr(obj, name)
    return (v,) if isinstance(v, float) else (v[0], v[1], v[2])


def field_offsets(obj, names):
    """{name: (offset in doubles, width)} of the fields `names` inside the C++ object of the
    wrapper `obj`: distinct exact binary fractions are written to the fields through the
    API, looked for in the object's first _SEARCH doubles (the first place each is found) and
    the fields restored."""
    kind = type(obj).__name__
    missing = [n for n in names if (kind, n) not in _field_found]
    if missing:
        address = state_address(obj)
        if address is None:
            raise CheckpointError("cannot locate a YADE object in memory: unexpected "
                                  "boost.python layout")
        # a Vector3r attribute is a view of the object's memory: saved as its values
        kinds = {n: type(getattr(obj, n)) for n in missing}
        saved = {n: _api_value(obj, n) for n in missing}
        as_api = lambda n, values: float(values[0]) if kinds[n] is float else \
            kinds[n](*[float(v) for v in values])
        probes, k = {}, 0
        try:
            for n in missing:
                probes[n] = 1000.0 + (k + np.arange(len(saved[n]))) / 16.0
                k += len(saved[n])
                setattr(obj, n, as_api(n, probes[n]))
            memory = np.ctypeslib.as_array(
                (ctypes.c_double * _SEARCH).from_address(address)).copy()
        finally:
            for n, values in saved.items():
                setattr(obj, n, as_api(n, values))
        for n, probe in probes.items():
            hits = [o for o in range(_SEARCH - len(probe) + 1)
                    if same_bits(memory[o:o + len(probe)], probe)]
            if not hits:
                raise CheckpointError(f"{kind}.{n} not found in memory: cannot read it in bulk")
            # the first: the search runs past the object's end into the heap, where the
            # temporary Vector3r that carried a probe through the API may lie (where, depends
            # on what was allocated before); the object's own field comes before anything
            # after it, and Fields verifies the place against the API on a sample
            _field_found[kind, n] = (hits[0], len(probe))
    return {n: _field_found[kind, n] for n in names}
