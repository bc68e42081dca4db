"""The schema of generic case files (docs/case-files.md): a DE part (built-in packings or a
user's YADE script), an FE mesh (box or gmsh), the DE zone and the coupling, time, sensors,
output; and the checks that need several keys at once."""
import math

import numpy as np

from orchestrator.casefile import (CASE, DENSITY, FACES, MODULUS, OUTPUT, REQUIRED, SEED,
                                   STRENGTH, UNSET, Key, axes, boolean, choice, components,
                                   divisions, integer, non_negative, number, poisson_range,
                                   positive, relaxation_kind, safety_range, step_count, string,
                                   strings, vector, within)
from orchestrator.coupling.bridging import WEIGHTINGS

MATERIAL = {
    "young": Key(number, 31e9, MODULUS), "poisson": Key(number, 0.2, poisson_range),
    "density": Key(number, 2400.0, DENSITY),
    "compressive_strength": Key(number, 31e6, STRENGTH),
    "tensile_strength": Key(number, 4.0e6, STRENGTH),
}
CPM = {"young": Key(number, UNSET, within(0, 1e13, "Pa")),
       "poisson": Key(number, UNSET, within(0, 1)),            # the links' shear / normal stiffness
       "frictionAngle": Key(number, UNSET, within(0, math.pi / 2, "rad")),
       "sigmaT": Key(number, UNSET, STRENGTH),
       "epsCrackOnset": Key(number, UNSET, within(0, 1)),
       "relDuctility": Key(number, UNSET, within(0, 1e4))}
PACKING = {"name": Key(string, UNSET), "lo": Key(vector, REQUIRED), "hi": Key(vector, REQUIRED),
           "radius": Key(number, REQUIRED, within(0, 1, "m")), "seed": Key(integer, 1, SEED),
           "velocity": Key(vector, [0.0, 0.0, 0.0])}
DIRICHLET = {"face": Key(choice(*FACES), REQUIRED), "components": Key(components, REQUIRED)}
SENSOR = {"name": Key(string, REQUIRED), "point": Key(vector, UNSET),
          "sphere": Key(integer, UNSET, non_negative), "on": Key(choice("auto", "de", "fe"), "auto")}

GENERIC = {
    "case": CASE,
    "de": {"script": Key(string, UNSET), "script_args": Key(strings, []),
           "packing": [PACKING], "current": Key(boolean, False)},
    "material": dict(MATERIAL, cpm=CPM),
    "fe": {"mesh": Key(string, "box"), "lo": Key(vector, UNSET), "hi": Key(vector, UNSET),
           "n": Key(divisions, UNSET), "cell": Key(choice("hexahedron", "tetrahedron"), "hexahedron"),
           "dirichlet": [DIRICHLET]},
    "coupling": {"zone_lo": Key(vector, REQUIRED), "zone_hi": Key(vector, REQUIRED),
                 "zone_axes": Key(axes, [0, 1]),
                 "layers": Key(integer, 3, within(1, 1000, low_open=False)),
                 "element_size": Key(number, UNSET, within(0, 1e3, "m")),
                 "variant": Key(choice("full", "diagonal"), "diagonal"),
                 "relaxation": Key(relaxation_kind, "auto", within(0, 1e6)),
                 "rotations": Key(boolean, True),
                 "weighting": Key(choice(*WEIGHTINGS), "consistent")},
    "time": {"dt_safety": Key(number, 0.3, safety_range),
             "dt": Key(number, UNSET, within(0, 1, "s")),      # and >= MIN_SAFETY × critical
             "duration": Key(number, UNSET, positive),        # and <= MAX_STEPS steps
             "steps": Key(integer, UNSET, step_count)},
    "sensors": [SENSOR],
    "output": OUTPUT,
}


def check(d, folder, problems):
    """Consistency of a generic case: one DE model, a usable mesh, a zone inside it."""
    de, fe, cp, time = d["de"], d["fe"], d["coupling"], d["time"]
    if de["current"]:
        if "script" in de or de["packing"]:
            problems.append("de.current = true: the YADE scene already built is the DE part "
                            "(cli.attach); give no de.script or [[de.packing]] with it")
    elif ("script" in de) == bool(de["packing"]):
        problems.append("de: give either de.script (a YADE script) or [[de.packing]] boxes, "
                        f"not {'both' if 'script' in de else 'neither'}")
    if "script" in de:
        de["script"] = _existing(folder, de["script"], "de.script", problems)
        for key in d["material"]["cpm"]:
            problems.append(f"material.cpm.{key}: only for built-in packings (the script "
                            f"makes its own materials)")
    for i, p in enumerate(de["packing"]):
        if _box_order(p["lo"], p["hi"], f"de.packing[{i}]", problems):
            _packing_size(p, f"de.packing[{i}]", problems)
    _box_order(cp["zone_lo"], cp["zone_hi"], "coupling.zone", problems, cp["zone_axes"])
    if ("duration" in time) == ("steps" in time) and not (de["current"] and not time.keys()
                                                          & {"duration", "steps"}):
        problems.append("time: give either time.duration (s) or time.steps, not "
                        f"{'both' if 'steps' in time else 'neither'}")
    for i, s in enumerate(d["sensors"]):
        if ("point" in s) == ("sphere" in s):
            problems.append(f"sensors[{i}] ({s['name']!r}): give either point or sphere")
        elif "sphere" in s and s["on"] == "fe":
            problems.append(f"sensors[{i}].on = 'fe': a sphere sensor is on the DE side")
    names = [s["name"] for s in d["sensors"]]
    for n in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"sensors: two sensors are named {n!r}")
    if fe["mesh"] == "box":
        missing = [k for k in ("lo", "hi", "n") if k not in fe]
        if missing:
            problems.append(f"fe.mesh = 'box' needs fe.{', fe.'.join(missing)}")
            return
        if _box_order(fe["lo"], fe["hi"], "fe", problems):
            _zone_on_box(fe, cp, problems)
    else:
        for k in ("lo", "hi", "n"):
            if k in fe:
                problems.append(f"fe.{k}: only for fe.mesh = 'box' (the mesh is {fe['mesh']!r})")
        fe["mesh"] = _existing(folder, fe["mesh"], "fe.mesh", problems)
        if "element_size" not in cp:
            problems.append("coupling.element_size: required with a gmsh mesh (the bridging "
                            "width is layers × element_size)")


MAX_SPHERES = 10**7          # ~13 kB per CPM sphere measured (1.5 GB for 116,280): 130 GB


def _packing_size(box, key, problems):
    """Refuse a packing far beyond any machine (e.g. a radius typed 10 × too small: 1000 ×
    the spheres), before the packing is made; dense packings fill ~60 % of their box."""
    n = 0.6 * np.prod(np.subtract(box["hi"], box["lo"])) / (4 / 3 * math.pi * box["radius"]**3)
    if n > MAX_SPHERES:
        problems.append(f"{key}.radius = {box['radius']!r}: about {n:.2g} spheres in this box, "
                        f"more than {MAX_SPHERES:.0e} (~13 kB each)")


def _existing(folder, name, key, problems):
    path = (folder / name).resolve()
    if not path.is_file():
        problems.append(f"{key} = {name!r}: file {path} not found")
    return str(path)


def _box_order(lo, hi, key, problems, axes=(0, 1, 2)):
    bad = [a for a in axes if not hi[a] > lo[a]]
    if bad:
        problems.append(f"{key}: hi {hi} must exceed lo {lo} along axis {bad[0]}")
    return not bad


def _zone_on_box(fe, cp, problems):
    """The DE zone is cut out of the box mesh: inside it, on its grid planes, and with room
    for the bridging layers; the bridging width defaults to layers × element size."""
    lo, hi, n = np.array(fe["lo"]), np.array(fe["hi"]), np.array(fe["n"])
    h = (hi - lo) / n
    axes = cp["zone_axes"]
    for bound in ("zone_lo", "zone_hi"):
        z = np.array(cp[bound])
        for a in axes:
            if not lo[a] <= z[a] <= hi[a]:
                problems.append(f"coupling.{bound}[{a}] = {z[a]!r}: the DE zone is outside the "
                                f"mesh, which spans [{lo[a]!r}, {hi[a]!r}] along axis {a}")
                continue
            i = (z[a] - lo[a]) / h[a]
            if abs(i - round(i)) > 1e-9:
                problems.append(f"coupling.{bound}[{a}] = {z[a]!r}: not on a grid plane of the "
                                f"box mesh (nearest: {lo[a] + math.floor(i) * h[a]!r}, "
                                f"{lo[a] + math.ceil(i) * h[a]!r})")
    if "element_size" not in cp:
        sizes = {round(h[a], 12) for a in axes}
        if len(sizes) > 1:
            problems.append(f"coupling.element_size: required, the box's elements differ along "
                            f"the zone axes {axes} (sizes {sorted(sizes)})")
            return
        cp["element_size"] = float(h[axes[0]])
