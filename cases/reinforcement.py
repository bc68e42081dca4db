"""Reinforcement layouts: layers of straight parallel bars in a box-shaped concrete member.

A layer is given by its bar diameter, the spacing of the bar axes, the direction of the bars
(x or y), the face it is near (bottom z = z_min or top z = z_max), the cover, and the steel's
Young's modulus, yield strength and density. `cover` is the distance from that face (and from
the box's sides) to the bar axes, so that a cover below the bar radius would put the bar outside
the concrete; the concrete cover to the bar surface is cover − diameter/2. Bars run along their
direction from cover to the box's length minus cover; across it, they are spaced `spacing`
apart, centred in the width, as many as fit between the two side covers.

Pure numpy: both partners (fenicsx_side.bars, yade_side.bars) take the `Bars` it makes.
"""
import math
from dataclasses import dataclass, fields

import numpy as np

DIRECTIONS = {"x": 0, "y": 1}
FACES = ("bottom", "top")


@dataclass
class Layer:
    diameter: float                 # m
    spacing: float                  # m, between bar axes
    direction: str                  # "x" or "y": the bars' axis
    cover: float                    # m, from the face (and the box's sides) to the bar axes
    face: str = "bottom"            # "bottom" (z min) or "top" (z max)
    young: float = 200e9            # Pa
    yield_strength: float = 500e6   # Pa
    density: float = 7850.0         # kg/m³
    bond_strength: float = None     # Pa, bar–concrete shear strength (DE bond links)
    hardening: float = 0.0          # Pa, the slope past fy (0: EN 1992-1-1's horizontal branch)

    def check(self, where="reinforcement"):
        """Raise ValueError naming `where`.key and the value for a bad number or choice."""
        for name in ("diameter", "spacing", "cover", "young", "yield_strength", "density"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{where}.{name} must be a positive number, got {v!r}")
        if not (isinstance(self.hardening, (int, float)) and math.isfinite(self.hardening)
                and 0 <= self.hardening < self.young):
            raise ValueError(f"{where}.hardening must be a number in [0, young) (Pa), got "
                             f"{self.hardening!r}")
        if self.bond_strength is not None and not (
                isinstance(self.bond_strength, (int, float)) and self.bond_strength > 0):
            raise ValueError(f"{where}.bond_strength must be a positive number (Pa), got "
                             f"{self.bond_strength!r}")
        if self.direction not in DIRECTIONS:
            raise ValueError(f"{where}.direction must be one of {tuple(DIRECTIONS)}, got "
                             f"{self.direction!r}")
        if self.face not in FACES:
            raise ValueError(f"{where}.face must be one of {FACES}, got {self.face!r}")
        if self.cover < self.diameter / 2:
            raise ValueError(f"{where}.cover = {self.cover!r} m is below the bar radius "
                             f"{self.diameter / 2!r} m: the bars would stick out of the concrete")
        if self.spacing < self.diameter:
            raise ValueError(f"{where}.spacing = {self.spacing!r} m is below the bar diameter "
                             f"{self.diameter!r} m: the bars would overlap")

    @property
    def area(self):
        return math.pi * self.diameter ** 2 / 4


def layer_from_dict(d, where="reinforcement"):
    """A checked Layer from a mapping (e.g. a case file's [[reinforcement]] table)."""
    known = {f.name for f in fields(Layer)}
    unknown = sorted(set(d) - known)
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(known))})")
    missing = [k for k in ("diameter", "spacing", "direction", "cover") if k not in d]
    if missing:
        raise ValueError(f"{where}: missing key {missing[0]!r}")
    layer = Layer(**d)
    layer.check(where)
    return layer


@dataclass
class Bars:
    """Straight bars: start, end (n, 3) points of their axes; per bar: diameter, young,
    yield_strength, density, bond_strength (NaN: not given), layer index, hardening (None:
    0)."""
    start: np.ndarray
    end: np.ndarray
    diameter: np.ndarray
    young: np.ndarray
    yield_strength: np.ndarray
    density: np.ndarray
    bond_strength: np.ndarray
    layer: np.ndarray
    hardening: np.ndarray = None

    def __post_init__(self):
        if self.hardening is None:
            self.hardening = np.zeros(len(self.start))

    def __len__(self):
        return len(self.start)

    def steel_step(self, bar, strain, plastic, accumulated):
        """The steel's law for members of bars `bar` at total axial strains `strain`: EN
        1992-1-1 3.2.7's bilinear curve, E up to fy, then the slope H (hardening; H = 0 the
        horizontal branch), in tension and compression, unloading at E: one-dimensional
        plasticity with linear isotropic hardening. The return mapping from the last state
        (plastic strain ε_p, accumulated plastic strain α: updated in place) is exact for any
        strain increment, so the law holds at every step whatever the step. Returns the axial
        stresses σ and the plastic work per unit volume of this increment, ∫ σ dε_p."""
        E, fy, H = self.young[bar], self.yield_strength[bar], self.hardening[bar]
        trial = E * (strain - plastic)
        excess = np.abs(trial) - (fy + H * accumulated)
        flow = np.where(excess > 0, excess / (E + H), 0.0)
        sign = np.sign(trial)
        work = flow * (fy + H * (accumulated + 0.5 * flow))
        plastic += sign * flow
        accumulated += flow
        return trial - sign * E * flow, work

    def steel_state(self, bar, volume):
        """The plastic state of members (chain links, truss elements) of bars `bar`, of the
        given steel volumes (weighted: the share of the bar they carry)."""
        return SteelState(self, np.asarray(bar, int), np.asarray(volume, float))

    @property
    def area(self):
        return np.pi * self.diameter ** 2 / 4

    @property
    def length(self):
        return np.linalg.norm(self.end - self.start, axis=1)

    @property
    def axis(self):
        """Unit vectors along the bars (n, 3)."""
        return (self.end - self.start) / self.length[:, None]

    def mass(self):
        return float(np.sum(self.density * self.area * self.length))


class SteelState:
    """Members of bars under the steel's law: plastic strain ε_p, accumulated α and the plastic
    work `work` (J) so far; `step(strain)` applies the law at the members' total strains and
    returns their stresses. history() / restore_history(h): for checkpoints."""

    def __init__(self, bars, bar, volume):
        self.bars, self.bar, self.volume = bars, bar, volume
        self.plastic = np.zeros(len(bar))
        self.accumulated = np.zeros(len(bar))
        self.work = 0.0

    def step(self, strain):
        stress, work = self.bars.steel_step(self.bar, strain, self.plastic, self.accumulated)
        self.work += float(work @ self.volume)
        return stress

    def history(self):
        return {"plastic": self.plastic, "accumulated": self.accumulated,
                "plastic_work": np.array(self.work)}

    def restore_history(self, h):
        self.plastic[:], self.accumulated[:] = h["plastic"], h["accumulated"]
        self.work = float(h["plastic_work"])


def bar_layout(layers, lo, hi, where="reinforcement"):
    """The bars of `layers` (Layer objects, checked here) in the box [lo, hi] (m). Refuses, with
    one line naming the layer's key and value, a layer whose bars fall outside the concrete
    (cover beyond the depth or the width), or whose bars cross another layer's."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi > lo):
        raise ValueError(f"{where}: the concrete box must have hi > lo on every axis, got "
                         f"{lo.tolist()}–{hi.tolist()}")
    parts, depths = [], []
    for k, layer in enumerate(layers):
        name = f"{where}[{k}]"
        layer.check(name)
        axis = DIRECTIONS[layer.direction]
        across = 1 - axis
        thickness = hi[2] - lo[2]
        if layer.cover > thickness - layer.diameter / 2:
            raise ValueError(f"{name}.cover = {layer.cover!r} m puts the bars outside the "
                             f"concrete: it is {thickness!r} m thick")
        width = hi[across] - lo[across] - 2 * layer.cover
        length = hi[axis] - lo[axis] - 2 * layer.cover
        if width < 0 or length <= 0:
            raise ValueError(f"{name}.cover = {layer.cover!r} m leaves no room for bars in the "
                             f"{hi[across] - lo[across]!r} × {hi[axis] - lo[axis]!r} m face")
        n = int(math.floor(width / layer.spacing + 1e-9)) + 1
        offsets = (np.arange(n) - (n - 1) / 2) * layer.spacing + 0.5 * (lo[across] + hi[across])
        z = lo[2] + layer.cover if layer.face == "bottom" else hi[2] - layer.cover
        start = np.empty((n, 3))
        start[:, across] = offsets
        start[:, 2] = z
        end = start.copy()
        start[:, axis] = lo[axis] + layer.cover
        end[:, axis] = hi[axis] - layer.cover
        parts.append((start, end, np.full(n, k)))
        depths.append((z, layer.diameter / 2, axis))
    for a in range(len(layers)):
        for b in range(a):
            (za, ra, axa), (zb, rb, axb) = depths[a], depths[b]
            # bars resting on each other (axes ra + rb apart) are fine: a relative tolerance
            # for the rounding of the depths
            if axa != axb and abs(za - zb) < (ra + rb) * (1 - 1e-9):
                raise ValueError(f"{where}[{a}].cover = {layers[a].cover!r} m: its bars cross "
                                 f"those of {where}[{b}] (axes {abs(za - zb):.4g} m apart, "
                                 f"radii {ra + rb:.4g} m)")
    if not parts:
        raise ValueError(f"{where}: no layer given")
    start, end, layer_index = (np.concatenate(p) for p in zip(*parts))
    per_bar = lambda attr: np.array([np.nan if getattr(layers[i], attr) is None
                                     else getattr(layers[i], attr) for i in layer_index], float)
    return Bars(start, end, per_bar("diameter"), per_bar("young"), per_bar("yield_strength"),
                per_bar("density"), per_bar("bond_strength"), layer_index,
                per_bar("hardening"))


def transformed_section(width, depth, young_concrete, bars_depth, bars_area, young_steel):
    """Uncracked transformed section of a rectangular beam (width × depth) with steel areas
    bars_area at depths bars_depth (from the top, m): n = E_s/E_c, the steel counted as
    (n − 1) A_s of extra concrete (the concrete it displaces removed). Returns (neutral axis
    depth from the top, second moment I_t about it), for the bending stiffness E_c I_t."""
    n = young_steel / young_concrete
    depths = np.atleast_1d(np.asarray(bars_depth, float))
    areas = np.broadcast_to(np.asarray(bars_area, float), depths.shape)
    a_c = width * depth
    extra = (n - 1) * areas
    y = (a_c * depth / 2 + np.sum(extra * depths)) / (a_c + np.sum(extra))
    inertia = width * depth ** 3 / 12 + a_c * (depth / 2 - y) ** 2 + np.sum(extra * (depths - y) ** 2)
    return float(y), float(inertia)
