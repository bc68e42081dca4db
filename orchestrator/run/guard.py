"""The blow-up guard of the run loop: NaN, inf or energy beyond a bound stop the run."""
import math

import numpy as np


class BlowUp(RuntimeError):
    pass


class BlowUpGuard:
    """Stops a run on NaN/inf or on energy above `growth` times the largest of the reference
    energy (e.g. the initial kinetic energy of the impactor) and the energy put in so far."""

    def __init__(self, reference_energy, growth=2.0):
        if not growth > 1:
            raise ValueError(f"energy growth limit must be > 1, got {growth!r}")
        self.reference = float(reference_energy)
        self.growth = float(growth)

    def check(self, step, energy, input_energy=0.0, **arrays):
        for name, a in arrays.items():
            if not np.all(np.isfinite(a)):
                raise BlowUp(f"step {step}: {name} is not finite (NaN or inf); "
                             f"the time step may be above a critical step")
        limit = self.growth * max(self.reference, input_energy)
        if not math.isfinite(energy) or (limit > 0 and energy > limit):
            raise BlowUp(f"step {step}: total energy {energy:.6g} J exceeds {self.growth:g} x "
                         f"the reference {max(self.reference, input_energy):.6g} J: unstable run "
                         f"(reduce the time step safety factor, or check the coupling)")
