"""The link-making step: exactly the pairs within the link reach become links, and the
candidate pairs are those of the 1.5 × bounds alone (no Verlet enlargement on that step)."""
import itertools

import numpy as np

from yade_side import import_yade
from yade_side.scene import INTERACTION_RADIUS, cpm_engines, create_cohesive_links, reset_scene

yade = import_yade()
O = yade.Omega()
R, N = 0.01, 5
SPACING = 1.8 * R  # links reach 3 R: face (1.8 R) and face-diagonal (2.55 R) neighbours only


def lattice_pairs(offsets):
    """Unordered pairs of an N³ lattice whose index offset is one of `offsets` (up to sign)."""
    return sum(int(np.prod([N - abs(o) for o in off])) for off in offsets)


def test_links_and_candidates_of_a_lattice():
    reset_scene()
    from yade import utils
    mat = O.materials.append(yade.wrapper.CpmMat(young=30e9, poisson=0.2, frictionAngle=0.67,
                                                 sigmaT=3e6, epsCrackOnset=1e-4,
                                                 relDuctility=30, density=4000))
    O.bodies.append([utils.sphere(tuple(SPACING * np.array(ijk)), R, material=mat)
                     for ijk in itertools.product(range(N), repeat=3)])
    cpm_engines(dt=1e-7)
    collider = O.engines[1]
    verlet = collider.verletDist
    create_cohesive_links()
    half = {o for o in itertools.product((-1, 0, 1), repeat=3) if o > (0, 0, 0)}
    links = [o for o in half if SPACING * np.linalg.norm(o) < 2 * INTERACTION_RADIUS * R]
    assert len(links) == 9  # 3 faces + 6 face diagonals
    assert O.interactions.countReal() == lattice_pairs(links) == 300 + 480
    # candidates: bounds of half-size 1.5 R overlap for lattice neighbours up to one step on
    # every axis (2 steps = 3.6 R > 3 R); a Verlet enlargement would add the 2-step pairs
    assert len(O.interactions) == lattice_pairs(half) == 300 + 480 + 256
    assert collider.verletDist == verlet
    O.step()  # the collider with its Verlet distance and 1 × bounds; links stay
    assert O.interactions.countReal() == 780
