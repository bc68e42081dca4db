"""The relaxation r of the diagonal (or full) multipliers for relaxation = "auto", from the
discretisation ratio (FE element size / sphere diameter), the number of bridging layers n_b,
the solver and Δt / the critical step (docs/wave1d.md)."""
import math


def auto_relaxation(ratio, layers, variant="diagonal", dt_safety=0.8):
    """Default r: a fit of the measured best r of this model (docs/wave1d.md).

    Relaxation acts per time step (each correction removes a fraction ~1/r of the gap), so
    the best r grows as the step shrinks, measured ∝ (Δt)^-3/2; it grows slowly with the
    ratio (the HF packet sits higher, √ratio × the bar's cut-off) and with n_b up to 4
    layers; the full solver needs about twice the diagonal's r.
    """
    r = (2.0 + 0.5 * ratio) * math.sqrt(min(layers, 4) / 3.0) * (0.8 / dt_safety) ** 1.5
    return round(2.0 * r if variant == "full" else r, 2)
