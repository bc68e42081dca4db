"""A coupled 3D elastic block: YADE spheres with elastic CPM links (never damaged) on
x < x_i + w, a dolfinx FE block on x > x_i, and a bridging band of `layers` FE element
layers (width w) between them, where both models exist (orchestrator.coupling.bridging.HalfSpaceZone).

Used by the exact coupled tests (free vibration, rigid motions) and by the paper's 3D check
(`python3 -m cli block3d`): the block is slowly sheared in the y–z plane by an affine
displacement u = f(t) B x imposed on its four faces y, z = const, whose exact answer is known
(below, `shear_gradient`).

With `uniform_weight` set, spheres and FE instead fill the whole block and every sphere is
coupled with the same α = w, β = 1 − w (`UniformOverlap`).

Two ways to weigh the energies in the bridging band (`weighting`):
- "nodal", the paper's (docs/method.md): α_i m_i ü_i = α_i Fg_i + …, β_j M_j d̈_j = β_j F_j − …;
  the weights cancel in the predictors. Not conservative when the weights vary: a ramped band
  makes the coupled system gain energy exponentially (docs/coupling.md, "Coupled 3D block");
- "consistent": each partner integrates its weighted energy, α H_FE (stiffness ∫ α ε:C:ε and
  mass ∫ α ρ N) and β H_DE (sphere masses × β, link forces × the mean β of the two spheres);
  the coupled system is then Hamiltonian and the leap-frog conserves its energy. Set up once,
  no cost per step.
"""
from dataclasses import dataclass

import numpy as np

from orchestrator.coupling.bridging import check_weighting

PACKINGS = ("random", "cubic")


def cubic_lattice(hi, radius):
    """Centres of a simple cubic lattice of spacing 2R filling the box [0, hi] (the outer
    spheres touch its faces), and their radii. Its cohesive links (made up to 1.5 × the sum
    of radii) join each sphere to its 6 face and 12 edge neighbours: a set with cubic
    symmetry, so under an affine displacement with the spheres rotating as ½ curl u the link
    forces and moments on every interior sphere cancel in opposite pairs."""
    axes = [np.arange(radius, h - radius * (1 - 1e-9), 2 * radius) for h in hi]
    centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return centres, np.full(len(centres), float(radius))


@dataclass
class BlockSpec:
    size: tuple = (0.12, 0.06, 0.06)   # block [0, Lx] × [0, Ly] × [0, Lz] (m)
    de_length: float = 0.048           # x_i: the DE zone is x < x_i
    radius: float = 0.003              # spheres
    element: float = 0.012             # FE element size (cubes)
    layers: int = 2                    # bridging layers
    young: float = 31e9                # FE: the concrete's macroscopic modulus
    poisson: float = 0.22
    density: float = 2400.0            # bulk density of both models
    contact_young: float = 33e9        # CPM contact modulus (platform calibration: E ≈ 31 GPa)
    contact_poisson: float = 0.2       # CPM shear/normal stiffness ratio
    dt_safety: float = 0.5             # × the smaller critical step
    variant: str = "full"
    relaxation: float = 1.0
    rotations: bool = True
    uniform_weight: float = None       # α everywhere: spheres and FE overlap on the whole block
    weighting: str = "consistent"      # or "nodal", the paper's (see above)
    packing: str = "random"            # "random" (dense random packing) or "cubic" (simple
                                       # cubic lattice of spacing 2R: an affine field is an
                                       # exact equilibrium of its links)

    def __post_init__(self):
        self.size = tuple(float(s) for s in self.size)
        for name in ("de_length", "radius", "element", "young", "density", "contact_young",
                     "contact_poisson", "relaxation"):
            if not getattr(self, name) > 0:
                raise ValueError(f"block: {name} must be > 0, got {getattr(self, name)!r}")
        if not 0 < self.dt_safety <= 1:
            raise ValueError(f"block: dt_safety must be in (0, 1], got {self.dt_safety!r}")
        check_weighting("block", self.weighting)
        if self.packing not in PACKINGS:
            raise ValueError(f"block: packing must be one of {PACKINGS}, got {self.packing!r}")
        if self.uniform_weight is not None and not 0 < self.uniform_weight < 1:
            raise ValueError(f"block: uniform_weight must be in (0, 1), got {self.uniform_weight!r}")
        cells = (np.array(self.size) - self.fe_lo) / self.element
        if np.any(np.abs(cells - np.round(cells)) > 1e-9) or np.any(np.round(cells) < 1):
            raise ValueError(f"block: the FE part {(np.array(self.size) - self.fe_lo).tolist()} m "
                             f"is not a whole number of elements of {self.element:g} m")
        if self.uniform_weight is None and self.de_length + self.width > self.size[0]:
            raise ValueError(f"block: DE zone {self.de_length:g} m + bridging band "
                             f"{self.width:g} m exceed the block length {self.size[0]:g} m")

    @property
    def width(self):
        return self.layers * self.element

    @property
    def fe_lo(self):
        """Lower corner of the FE mesh."""
        return np.array([0.0 if self.uniform_weight is not None else self.de_length, 0.0, 0.0])

    @property
    def de_hi(self):
        """Upper corner of the box the spheres fill."""
        if self.uniform_weight is not None:
            return np.array(self.size)
        return np.array([self.de_length + self.width, self.size[1], self.size[2]])


class UniformOverlap:
    """Weights of a full overlap: α = weight at every FE node, β = 1 − weight at every sphere,
    every sphere coupled (duck-types orchestrator.coupling.bridging.Bridging)."""

    def __init__(self, weight):
        self.weight = float(weight)

    def alpha(self, x):
        return np.full(len(np.atleast_2d(x)), self.weight)

    def beta(self, x):
        return np.full(len(np.atleast_2d(x)), 1.0 - self.weight)

    share = alpha

    def contains(self, x, tol=0.0):
        return np.ones(len(np.atleast_2d(x)), bool)

    covers = contains
