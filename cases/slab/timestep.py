"""The slab's time step chosen by the run (`dt_safety = "auto"`): the largest of a ladder of
steps whose short pre-run keeps the model's energy within 1 % of the impact energy of the
same pre-run at half that step, over the first millisecond of contact.

Why a pre-run and not a formula: the elastic lattice is stable far above these steps (its
Gershgorin bound, from the stiffest links, is 0.6 × PWave at small scale, and energy is
conserved at 0.8 × for elastic motion: docs/performance.md); what limits the step under an
impact is the damaged links' shear and friction, which no stiffness bound sees. A step at which
a run gains energy differs from its half step by far more than a converged one does (small
slab, 40 m/s, seed 1: without the shear release 4.3 % at 0.3 and 1.8 % at 0.15; with it 1.35 %
at 0.3, 0.75 % at 0.2: docs/performance.md, section 5). The energy is the run's own check
(orchestrator.builder.Model.energy: kinetic, CPM elastic and FE)."""
import math
from dataclasses import replace
from time import perf_counter

import numpy as np

# from the largest down; if no rung passes, the last one is taken and the record says so
LADDER = (0.5, 0.4, 0.3, 0.2, 0.15)
TOLERANCE = 0.01         # of the impact energy
AFTER_CONTACT_S = 1e-3
SAMPLES = 50             # energy samples over a pre-run


def energy_history(spec, model, safety):
    """Times and energies (orchestrator.builder.Model.energy) of `model` at dt_safety =
    `safety` from the start to AFTER_CONTACT_S after contact; and the impact energy."""
    from cases.slab.model import SlabModel
    m = SlabModel(replace(spec, dt_safety=safety), model)
    end = spec.impactor_gap / spec.impactor_speed + AFTER_CONTACT_S
    steps = math.ceil(end / m.dt)
    every = max(1, steps // SAMPLES)
    t, e = [m.O.time], [m.energy()]
    for n in range(1, steps + 1):
        m.step()
        if n % every == 0:
            t.append(m.O.time)
            e.append(m.energy())
    return np.array(t), np.array(e), 0.5 * m.impactor.mass.sum() * spec.impactor_speed**2


def deviation(safety, history):
    """Largest |E(t) − E_half(t)| / impact energy over the pre-run, E_half from the pre-run at
    half the step (interpolated to the same times); `history(safety)` -> (t, E, impact)."""
    t, e, impact = history(safety)
    t_half, e_half, _ = history(safety / 2)
    return float(np.max(np.abs(e - np.interp(t, t_half, e_half))) / impact)


def choose(spec, model, history=energy_history, log=print):
    """`spec` (dt_safety "auto") with dt_safety the ladder's largest passing step (the last
    rung if none passes) and dt_choice what was tried: {"rule", "tried": [[safety, deviation],
    ...], "dt_safety", "passed", "pre_run_s"}. Each pre-run is made once (a rung's half step
    may be a lower rung)."""
    t0 = perf_counter()
    made = {}

    def once(safety):
        if safety not in made:
            made[safety] = history(spec, model, safety)
        return made[safety]
    tried = []
    for safety in LADDER:
        d = deviation(safety, once)
        tried.append([safety, d])
        log(f"slab: time step {safety:g} × critical: energy within {100 * d:.2f} % of the half "
            f"step's over {1e3 * AFTER_CONTACT_S:g} ms of contact"
            f"{'' if d <= TOLERANCE else f' (more than {100 * TOLERANCE:g} %)'}")
        if d <= TOLERANCE:
            break
    else:
        log(f"slab: no step of {', '.join(map(str, LADDER))} × critical keeps its energy within "
            f"{100 * TOLERANCE:g} % of its half step's: {safety:g} taken")
    choice = {"rule": f"dt_safety auto: the largest of {', '.join(map(str, LADDER))} × critical "
                      f"whose energy stays within {100 * TOLERANCE:g} % of the impact energy of "
                      f"the half step's over the first {1e3 * AFTER_CONTACT_S:g} ms of contact "
                      f"(else {LADDER[-1]})",
              "tried": tried, "dt_safety": safety, "passed": tried[-1][1] <= TOLERANCE}
    choice["pre_run_s"] = perf_counter() - t0
    return replace(spec, dt_safety=safety, dt_choice=choice)
