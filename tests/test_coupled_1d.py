"""The coupled time step on pure-numpy 1D partners (a spring chain and a lumped bar)."""
import numpy as np
import pytest

from orchestrator.coupling.bridging import Bridging, HalfSpaceZone
from orchestrator.coupling.correction import Coupling
from orchestrator.stepper import CoupledStepper
from partners1d import Bar, Chain

E, A, RHO = 30e9, 1e-2, 2400.0
C = np.sqrt(E / RHO)


def overlapped(variant, relaxation=1.0, weight=0.5, ratio=5, elements=10):
    """Bar and chain over the same [0, 1] m, every sphere coupled, uniform α = β = weight."""
    h = 1.0 / elements
    L = h / ratio
    bar = Bar(0.0, h, elements, E, A, RHO)
    chain = Chain(0.0, L, elements * ratio + 1, RHO * A * L, E * A / L)
    dt = 0.5 * L / C
    chain.dt = dt
    k, h_op = bar.point_operators(chain.pos0)
    n = len(chain.mass)
    cpl = Coupling(k, h_op, chain.mass, np.ones(n), np.full(n, 1 - weight), bar.mass,
                   np.full(bar.mass.size, weight), bar.fixed, dt, variant=variant,
                   relaxation=relaxation, rotations=False)
    # a smooth initial field that satisfies the constraints: d = k u
    bar.u[0::3] = 1e-5 * np.cos(np.pi * bar.nodes[:, 0])
    chain.d[:] = k @ bar.u
    bridge = chain.bridge(np.arange(n))
    return CoupledStepper(chain.step, bridge, bar, cpl), bar, chain


def invariant(bar, chain, x_prev, weight):
    """Leap-frog's conserved energy ½ vᵀW v + ½ x(n+1)ᵀ K x(n) of the weighted system."""
    kin = 0.5 * weight * bar.mass @ bar.v**2 + 0.5 * (1 - weight) * np.repeat(chain.mass, 3) @ chain.v**2
    u0, d0 = x_prev
    pot = 0.5 * weight * bar.u @ (bar.K @ u0) + 0.5 * (1 - weight) * chain.d @ (chain.K @ d0)
    return kin + pot


def run_invariant(variant, relaxation=1.0, steps=3000):
    stepper, bar, chain = overlapped(variant, relaxation)
    e = []
    for _ in range(steps):
        x_prev = (bar.u.copy(), chain.d.copy())
        stepper.step()
        e.append(invariant(bar, chain, x_prev, 0.5))
    return np.array(e), stepper


def test_full_lagrange_conserves_the_leapfrog_invariant_exactly():
    """With uniform weights the constrained system is symmetric: central differences with
    exact linear constraints (SHAKE) conserve the invariant to round-off."""
    e, stepper = run_invariant("full")
    assert np.abs(e - e[0]).max() < 1e-10 * e[0]
    assert np.abs(stepper.last.q - stepper.last.Gu).max() < 1e-12 * 1e-5
    # several periods of the fundamental mode were run: the test is not trivially short
    period = 2.0 / C  # free-free bar of 1 m, first mode
    assert 3000 * stepper.dt > 2 * period


@pytest.mark.parametrize("variant,relaxation", [("diagonal", 1.0), ("full", 35.0), ("diagonal", 35.0)])
def test_relaxed_variants_do_not_create_energy(variant, relaxation):
    e, _ = run_invariant(variant, relaxation)
    assert np.all(np.isfinite(e))
    assert e.max() <= e[0] * (1 + 1e-9), f"energy grew by {e.max() / e[0] - 1:.3e}"


def test_full_lagrange_holds_constraints_through_a_ramped_bridging_domain():
    """FE on [0, 2], chain on [1.7, 3]: 3 bridging layers with α, β ramps; a pulse from the
    chain's free end crosses into the bar and the constraints hold to round-off each step."""
    h, ratio = 0.1, 5
    L = h / ratio
    bar = Bar(0.0, h, 20, E, A, RHO)
    chain = Chain(1.7, L, int(round(1.3 / L)) + 1, RHO * A * L, E * A / L)
    chain.dt = dt = 0.5 * L / C
    br = Bridging(HalfSpaceZone([2.0, 0, 0], [-1.0, 0, 0]), layers=3, element_size=h)
    idx = np.flatnonzero(br.contains(chain.pos0, tol=1e-9))
    k, h_op = bar.point_operators(chain.pos0[idx])
    cpl = Coupling(k, h_op, chain.mass[idx], np.ones(idx.size), br.beta(chain.pos0[idx]),
                   bar.mass, np.repeat(br.alpha(bar.nodes), 3), bar.fixed, dt, rotations=False)
    stepper = CoupledStepper(chain.step, chain.bridge(idx), bar, cpl)
    period = 20 * h / C
    for n in range(int(3 * period / dt)):
        t = (n + 1) * dt
        chain.d[-3] = 1e-5 * np.sin(np.pi * t / period) ** 2 if t < period else 0.0
        c = stepper.step()
        assert np.abs(c.q - c.Gu).max() <= 1e-9 * 1e-5
    assert np.abs(bar.u[0::3]).max() > 0.5e-5, "the pulse reached the FE bar"
