"""Assembling a coupling from the two partners: which spheres are coupled, the weights, the
operators, the common time step. Duck-typed on the partners (orchestrator.contracts)."""
import numpy as np

from orchestrator.coupling.correction import Coupling


def bridging_spheres(bridging, centres, tol=0.0):
    """Indices of the sphere centres that lie in the bridging domain."""
    return np.flatnonzero(bridging.contains(np.asarray(centres, float), tol))


# A step below this × the critical one buys nothing and costs steps without end (the slab's
# default run would take 10⁸ of them); the relaxation rule reads the factor to 6 digits.
MIN_SAFETY = 1e-3


def time_step(de_critical, fe_critical, safety=None, dt=None, source="dt"):
    """The common time step: `dt` if given (set by `source`), else safety × the smaller
    critical step; both partners must be stable alone, and a given dt at least MIN_SAFETY ×
    the smaller critical step. ValueError, one line per problem."""
    problems = []
    for name, value in (("DE", de_critical), ("FE", fe_critical)):
        if not value > 0:
            problems.append(f"{name} critical time step must be > 0, got {value!r}")
    if dt is None:
        if not (safety is not None and 0 < safety <= 1):
            problems.append(f"time step safety factor must be in (0, 1], got {safety!r}")
        if problems:
            raise ValueError("\n".join(problems))
        return safety * min(de_critical, fe_critical)
    for name, value in (("DE", de_critical), ("FE", fe_critical)):
        if dt > value:
            problems.append(f"{source} = {dt:.4g} s: above the {name} critical step "
                            f"{value:.4g} s (the run would blow up)")
    least = MIN_SAFETY * min(de_critical, fe_critical)
    if not problems and dt < least:
        problems.append(f"{source} = {dt:.4g} s: below {MIN_SAFETY:g} × the smaller critical "
                        f"step, {least:.4g} s (a run of steps without end)")
    if problems:
        raise ValueError("\n".join(problems))
    return dt


def make_coupling(fe, bridging, bridge, dt, variant="full", relaxation=1.0, rotations=True,
                  backend="auto", nodal_weights=True, exact_ratio=True):
    """Coupling of the bridge spheres (`bridge.ref_pos`, `mass`, `inertia`) to the FE model.
    nodal_weights: α and β weigh the multipliers (the paper's); False when both partners
    already integrate their weighted energies (the consistent weighting: weights inside their
    masses and stiffnesses, so α = β = 1 here); exact_ratio: see Coupling."""
    k, h = fe.point_operators(bridge.ref_pos)
    beta = bridging.beta(bridge.ref_pos) if nodal_weights else np.ones(len(bridge.ref_pos))
    alpha = bridging.alpha(fe.nodes) if nodal_weights else np.ones(len(fe.nodes))
    return Coupling(k, h if rotations else None, bridge.mass, bridge.inertia, beta, fe.mass,
                    np.repeat(alpha, 3), fe.fixed, dt, variant=variant, relaxation=relaxation,
                    rotations=rotations, backend=backend, exact_ratio=exact_ratio)
