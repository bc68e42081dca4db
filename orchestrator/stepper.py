"""The coupled time step, with the time split between the partners.

- `de_step()`: advances every sphere one step alone (YADE's O.step(): Newton = central
  differences, so the positions it leaves are the predictor);
- `bridge`: the coupled spheres (orchestrator.contracts.SphereSet);
- `fe`: the FE partner (orchestrator.contracts.FEPartner).
Corrections go to positions and half-step velocities together, so both stay exact
central-difference updates (docs/method.md, eqs. 15–17).
"""
from time import perf_counter

from orchestrator.coupling.exchange import ExchangeMeter


class CoupledStepper:
    def __init__(self, de_step, bridge, fe, coupling):
        self.de_step = de_step
        self.bridge = bridge
        self.fe = fe
        self.coupling = coupling
        self.dt = coupling.dt
        self.exchange = ExchangeMeter()
        self.seconds = {"yade": 0.0, "fe": 0.0, "coupling": 0.0}
        self.steps = 0
        self.last = None

    def step(self):
        t0 = perf_counter()
        self.de_step()
        self.seconds["yade"] += perf_counter() - t0
        return self.couple()

    def couple(self):
        """What follows the DE predictor: FE predictor, multipliers, corrections. Called by
        step(), or by a DE engine placed right after the integrator (yade_side.user_script)."""
        dt = self.dt
        t1 = perf_counter()
        self.fe.predict(dt)
        t2 = perf_counter()
        self.bridge.predict(dt)
        c = self.coupling.correct(self.bridge.displacement(), self.bridge.rotation_pred, self.fe.u)
        self.bridge.correct(c.dd, c.dw, dt)
        self.fe.correct(c.fe_dofs, c.du, dt)
        self.exchange.update(c)
        t3 = perf_counter()
        self.seconds["fe"] += t2 - t1
        self.seconds["coupling"] += t3 - t2
        self.steps += 1
        self.last = c
        return c
