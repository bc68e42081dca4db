"""The written contracts between the layers: what the coupling sees of each partner, what the
builder needs of a DE scene, and what the run loop sees of a model. `typing.Protocol` classes:
yade_side.bulk.BodySet, fenicsx_side.model.ElasticModel (and its MPI proxy) and
orchestrator.builder.Model satisfy them without inheriting from them."""
from typing import Callable, Optional, Protocol

import numpy as np


class SphereSet(Protocol):
    """The coupled spheres, as the coupling sees them (yade_side.bulk.BodySet)."""
    ids: np.ndarray
    ref_pos: np.ndarray       # (n, 3) positions when the set was made
    mass: np.ndarray          # (n,)
    inertia: np.ndarray       # (n,) scalar inertia of a sphere
    radius: np.ndarray
    rotation: np.ndarray      # (n, 3) accumulated rotation vector
    rotation_pred: np.ndarray

    def predict(self, dt: float) -> None: ...
    def displacement(self) -> np.ndarray: ...
    def correct(self, dd: np.ndarray, dtheta: np.ndarray, dt: float) -> None: ...


class FEPartner(Protocol):
    """The FE model, as the coupling and the run loop see it (fenicsx_side.model.ElasticModel)."""
    nodes: np.ndarray         # (n_nodes, 3)
    mass: np.ndarray          # (ndof,) lumped
    fixed: np.ndarray         # (ndof,) mask of Dirichlet dofs
    u: np.ndarray
    v: np.ndarray
    t: float
    distributed: bool         # state spread over MPI ranks (no checkpoints)

    def predict(self, dt: float) -> None: ...
    def correct(self, dofs: np.ndarray, du: np.ndarray, dt: float) -> None: ...
    def point_operators(self, points: np.ndarray): ...
    def check_covered(self, points: np.ndarray) -> None: ...
    def critical_dt(self) -> float: ...
    def critical_dt_bound(self) -> float: ...   # a lower bound, cheaper (a grown zone's check)
    def kinetic_energy(self) -> float: ...
    def strain_energy(self) -> float: ...
    def stress(self): ...


class DEScene(Protocol):
    """How a case makes its YADE scene, for orchestrator.builder.assemble."""
    time_step: tuple          # (dt, what set it) of a scene that sets its own step (a
                              # script's O.dt), else (None, "")

    def place(self, keep: Optional[Callable]) -> np.ndarray:
        """Make the scene's bodies; keep(centres) -> mask selects the spheres of a coupled
        model (None: all). Returns the ids of the spheres the model measures and couples."""

    def extend(self, keep: Callable, earlier: "DEScene") -> np.ndarray:
        """For a DE zone grown in place: add to the running scene the spheres keep(centres)
        selects that the scene `earlier` (the model's before it grew) did not place, at their
        reference positions; returns the ids of every sphere the model measures and couples,
        earlier's first in its order."""

    def critical_dt(self, beta: np.ndarray) -> float:
        """The DE critical step, with the spheres' weights β (1 for the nodal weighting)."""

    def start(self, dt: float) -> bool:
        """Engines at `dt` and what follows them; True when the cohesive links now exist,
        False when the first step makes them."""

    def attach(self, couple: Callable) -> bool:
        """Run `couple` inside each step, right after the integrator (True), or leave it to
        the stepper after each step (False)."""


class DEBars(Protocol):
    """Members of the DE model that are not its measured material (reinforcement bars: the
    slab's cases.slab.reinforced.DEBars), for orchestrator.builder.assemble: weighted and
    coupled like the scene's spheres, left out of damage and sensors."""

    def place(self) -> np.ndarray:
        """Add their spheres (those of the model being built) after the scene's bodies;
        returns their ids."""

    def start(self) -> None:
        """Called once the scene's engines and cohesive links exist (before the weighting)."""

    def step(self) -> None:
        """Called after every step of the model (their own law: the steel's plasticity)."""

    def history(self) -> dict:
        """Arrays of their state beyond the YADE scene, for checkpoints."""

    def restore_history(self, history: dict) -> None: ...


class RunModel(Protocol):
    """A model, as the run loop sees it (orchestrator.builder.Model)."""
    dt: float
    critical: dict
    fe: Optional[FEPartner]
    stepper: object            # orchestrator.stepper.CoupledStepper, or None for DE alone
    spheres: object            # the measured spheres (a BodySet)
    damage: object             # yade_side.damage.LinkDamage over them
    bridge_index: np.ndarray
    in_de_zone: np.ndarray
    sensor_names: list
    sensor_positions: np.ndarray
    seconds: dict

    def step(self) -> None: ...
    def sensor_displacements(self) -> np.ndarray: ...
    def energy(self) -> float: ...
    def sphere_count(self) -> int: ...
    def de_history(self) -> dict: ...
    def restore_de_history(self, history: dict) -> None: ...
