"""The energy the coupling exchanges, measured from its corrections."""
import numpy as np


class ExchangeMeter:
    """Work of the multiplier forces, accumulated with the central-difference rule
    W += f(t)·(x(t+Δt) − x(t−Δt))/2 from the corrections of successive steps (x: the corrected
    sphere dofs q and the constrained FE values G u).

    `to_fe`: energy given to the FE model; `net`: energy the coupling creates or dissipates
    (zero when the constraints hold exactly, as with the full solver and r = 1).
    """

    def __init__(self):
        self.to_fe = 0.0
        self.net = 0.0
        self._history = []  # corrected (q, Gu) of the last two steps

    def update(self, corr):
        # f·G(u2 − u0) as (Gᵀf)·(u2 − u0): no extra product with G per step
        self._history.append((corr.q, corr.u))
        if len(self._history) == 3:
            (q0, u0), _, (q2, u2) = self._history
            to_fe = 0.5 * float(corr.fe_force @ (u2 - u0))
            self.to_fe += to_fe
            self.net += to_fe - 0.5 * float(corr.force @ (q2 - q0))
            self._history.pop(0)

    def state(self):
        """What a checkpoint keeps (arrays)."""
        q, u = zip(*self._history) if self._history else ((), ())
        return {"to_fe": np.array(self.to_fe), "net": np.array(self.net),
                "q": np.array(q), "u": np.array(u)}

    def restore(self, state):
        self.to_fe, self.net = float(state["to_fe"]), float(state["net"])
        self._history = list(zip(state["q"], state["u"]))
