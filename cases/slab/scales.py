"""The slab's dimensions, its one table of scales (what depends on the sphere size), and the
concrete of each scale: the CPM sets fitted on the scale's packing with the measured response
that the FE takes its material from (docs/slab.md, docs/calibration.md)."""
import functools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SLAB = (2.5, 2.0, 0.28)


@dataclass(frozen=True)
class Scale:
    """What depends on the sphere size (docs/slab.md, docs/calibration.md)."""
    radius: float        # m
    steps: int           # at STEPS_SAFETY: 7 ms, the 10 m/s first peak and rebound (below)
    fe_young: float      # FE modulus: the bending modulus of the DE slab it stands for
    de_zone: float       # side of the DE zone along x (m)
    full_width: bool     # the DE zone spans the slab's whole width (y)
    layers: int          # bridging layers n_b


# - radius: 25,072 spheres in the full medium model, 122,066 at paper scale (the paper's
#   Table 1: 120,808);
# - fe_young: measured by quasi-static 3-point bending of a strip of the slab's packing
#   against the same strip in FE on the scale's grid (`python3 -m cases.slab.bending --scale
#   S`): 5.6-7.6 sphere diameters through 0.28 m bend like 20-23 GPa, not the 31 GPa of their
#   uniaxial test (small 20.15, medium 22.60 GPa with the refitted plain sets; 17.2 and 21.0
#   GPa with the sets before, whose uniaxial E was 26.5 and 29.6 GPa on today's packings);
#   12.5 diameters like 23.83 GPa (paper, the refitted plain set: a strip of 17,721 spheres,
#   26 min; 24.9 GPa with the set before, whose uniaxial E was 31.9 GPa, now 31.0; figures
#   made with it in the docs give `--young 24.9e9`);
# - de_zone, full_width, layers: a 0.5 m box under the impact with one bridging layer at every
#   scale, the zone the run grows from by default (`--zone grow`, docs/auto-zone.md) and the
#   fixed zone of `--zone box`: at small scale, with FE damage, it was within the full model's
#   scatter at 10 and 20 m/s, 3.0-4.6 x per step (docs/auto-zone.md, "Trip levels against the
#   ensembles"), ~9 x fewer spheres at paper scale (docs/where-coupling-pays.md). At 40 m/s damage reaches
#   the free edges y = 0, 2 within 5 ms: the grown zone says that coupling cannot pay. The
#   full-width strips of the map (docs/where-coupling-pays.md) are `--de-zone 0.6` (small),
#   `0.9` (medium) `--full-width --layers 3`.
# - steps: 7 ms (TABLE_DURATION): the full slab at 10 m/s (seed 1) sinks to its first peak
#   at 5.2 ms under the impact and 6.0 ms at the far sensors (small), 5.2 and 4.7 ms
#   (medium), and is back to half of it by 6.7 and 6.9 ms (`slab --model full
#   --impactor-speed 10 --steps 4950 [--scale medium --steps 6600]`, then the sensors.csv);
#   where the event's end is measured, the default window is its duration (DURATIONS). The
#   paper scale keeps a short default (a full member is hours): give --steps.
SCALES = {
    "small": Scale(0.025, 4950, 20.2e9, 0.5, False, 1),
    "medium": Scale(0.0185, 6400, 22.6e9, 0.5, False, 1),
    "paper": Scale(0.0112, 300, 23.8e9, 0.5, False, 1),
}
# the table's steps are at this × the critical step: the duration is what is kept
STEPS_SAFETY = 0.15
TABLE_DURATION = 7e-3     # s, what the table's steps hold at small and medium scale
# the impact's duration (s) by scale and impact speed where the full model has measured it:
# the latest end of the event over the full members of seeds 1-6 (the impactor stopped,
# rebounded or through, then the slab's centre risen back by half its depth, or where the
# slab breaks under the impact and its centre never rises, the impactor's end alone:
# cases.slab.quantities.event_ends, which `compare` prints) + 10 %, rounded up to 0.5 ms:
# - small, 10 m/s: 7.28 ms (seed 2; the others 6.37-7.12 ms), `slab --model full --scale
#   small --impactor-speed 10 --seeds 1,2,3,4,5,6 --steps 4240` (12 ms), then `compare`;
# - small, 40 m/s: the impactor's end, 5.01-9.34 ms (the slab's centre scabs and never
#   rises, its sides still sink at 25 ms), the same with `--impactor-speed 40 --steps 8840`;
# - small, 20 m/s: not measured: in 12 ms runs (`--impactor-speed 20 --steps 4240`) the
#   event ends in seeds 1 and 2 only (8.4, 8.7 ms); the impactors of seeds 3 and 6 still ride
#   the slab down at 0.25-0.48 m/s, the centres of seeds 4 and 5 have not risen back. It
#   takes the longer of its neighbours' windows, 10.5 ms, shorter than that impact.
DURATIONS = {"small": {10: 8.0e-3, 40: 10.5e-3}}


def duration(scale, speed):
    """The default window (s) of an impact at `speed` (m/s) at `scale`: the measured duration
    at that speed, else the longer of the two measured speeds around it (the nearest one
    beyond them); TABLE_DURATION where none is measured (medium; paper keeps its short
    table)."""
    measured = DURATIONS.get(scale)
    if not measured:
        return TABLE_DURATION
    below = [v for v in measured if v <= speed]
    above = [v for v in measured if v >= speed]
    near = ([max(below)] if below else []) + ([min(above)] if above else [])
    return max(measured[v] for v in near)
# the fields that default to the table's value of the scale (None: take the scale's)
PER_SCALE = {"radius": "radius", "young": "fe_young",
             "de_zone": "de_zone", "full_width": "full_width", "layers": "layers"}
# the slab's CPM concrete: "plain" fitted to E and fc (relDuctility 30, no shear damage), "gf"
# also brought towards the fracture energy (docs/calibration.md)
CONCRETES = ("plain", "gf")

# `python3 -m cli calibrate --scale S --measure-only ...` of each set, its calibration.json as
# written (calibrations/README.md gives the commands)
CALIBRATIONS = Path(__file__).with_name("calibrations")


@dataclass(frozen=True)
class Concrete:
    """A CPM set of one scale and what its uniaxial tests measured on the scale's packing."""
    cpm: dict                   # CpmMat micro-parameters (the bulk density apart)
    young: float                # E (Pa) of the compression test, between gauges mid-specimen
    poisson: float              # ν
    compressive_strength: float  # fc (Pa)
    tensile_strength: float     # ft (Pa): the tension (or separation) test's peak
    fracture_energy: float      # Gf (J/m²) of the separation test, None without one (a lower
                                # bound if the specimen did not separate: the record says)
    record: str                 # the calibration.json it comes from
    compression: tuple          # the compression test: (strain, stress) arrays, length (m),
                                # modulus between the ends (Pa)

    def compressive_fracture_energy(self, young, width):
        """Gc of an FE compression band of cells `width` wide and modulus `young` that follows
        this set's measured post-peak branch (fenicsx_side.damage_law)."""
        from fenicsx_side.damage_law import fit_compressive_fracture_energy
        strain, stress, length, specimen_young = self.compression
        return fit_compressive_fracture_energy(strain, stress, length, specimen_young, young,
                                               width)[0]


@functools.cache
def concrete_set(scale, name):
    """The set `name` of `scale`, from its calibration record; None if the scale has none.
    Where the record has no Gf (its separation test's balance failed at the calibration's
    step), `SCALE-NAME-separation.json` gives it: the same set's separation test at the slab's
    own step and shear release (calibrations/README.md), its params the record's."""
    path = CALIBRATIONS / f"{scale}-{name}.json"
    if not path.is_file():
        return None
    record = json.loads(path.read_text())
    m = record["measured"]
    cpm = {k: v for k, v in record["params"].items() if k != "density"}
    curve = record["curves"]["compression"]
    gf = m.get("fracture_energy")
    separation = CALIBRATIONS / f"{scale}-{name}-separation.json"
    if gf is None and separation.is_file():
        test = json.loads(separation.read_text())
        if test["params"] != record["params"]:
            raise ValueError(f"{separation}: params are not those of {path.name}: not the "
                             f"same CPM set")
        gf = test["measured"]["fracture_energy"]
    return Concrete(cpm, m["E"], m["nu"], m["fc"], m["ft"], gf,
                    str(path.relative_to(Path(__file__).parents[2])),
                    (np.array(curve["strain"]), np.array(curve["stress"]), record["size"][0],
                     m["E_ends"]))
