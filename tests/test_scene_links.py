"""The link-making step: exactly the pairs within the link reach become links, and the
candidate pairs are those of the 1.5 × bounds alone (no Verlet enlargement on that step); the
consistent weighting of links and of the contacts made later."""
import itertools

import numpy as np
import pytest

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


def test_weighted_spheres_weight_their_links_and_later_contacts_by_the_mean_beta():
    """The consistent weighting (yade_side.weighting): a link that exists when the weights are
    set, and a contact that closes later, both get the stiffness × the mean β of their two
    spheres, once; an unweighted pair keeps its own. Three pairs along x: linked (β 0.2, 0.6),
    apart then pushed into contact (β 0.2, 0.6), apart then pushed (β 1)."""
    from yade import utils
    from yade_side.weighting import weight_links, weight_masses
    reset_scene()
    mat = O.materials.append(yade.wrapper.CpmMat(young=30e9, poisson=0.2, frictionAngle=0.67,
                                                 sigmaT=3e6, epsCrackOnset=1e-4,
                                                 relDuctility=30, density=4000))
    centres = [(0, 0, 0), (1.9 * R, 0, 0), (0, 1, 0), (4 * R, 1, 0), (0, 2, 0), (4 * R, 2, 0)]
    ids = np.array(O.bodies.append([utils.sphere(c, R, material=mat) for c in centres]))
    cpm_engines(dt=1e-8)
    create_cohesive_links()
    link_kn = O.interactions[0, 1].phys.kn
    beta = np.array([0.2, 0.6, 0.2, 0.6, 1.0, 1.0])
    weight_masses(ids, beta)
    weight_links(ids, beta)
    assert O.interactions[0, 1].phys.kn == link_kn * 0.4
    for i in (3, 5):                            # into contact, as the link's pair
        O.bodies[i].state.pos = (1.9 * R, centres[i][1], 0)
    for b in O.bodies:
        b.state.blockedDOFs = "xyzXYZ"
    O.step()
    O.step()
    weighted, plain = O.interactions[2, 3].phys, O.interactions[4, 5].phys
    assert not weighted.isCohesive and not plain.isCohesive
    assert weighted.kn == pytest.approx(plain.kn * 0.4, rel=1e-15)
    assert O.interactions[0, 1].phys.kn == link_kn * 0.4


def test_a_reweighted_sphere_keeps_its_own_material_copy():
    """weight_contacts, for spheres that carried weights (a zone grown in place): a sphere
    weighted anew gets its own copy of its material, one already weighted has its copy
    reweighted in place (no material added), young × β / β_before either way; the shared
    material of the unweighted spheres is left as it was."""
    from yade import utils
    from yade_side.weighting import OWN_COPY, weight_contacts
    reset_scene()
    mat = O.materials.append(yade.wrapper.CpmMat(young=30e9, poisson=0.2, density=4000))
    ids = np.array(O.bodies.append([utils.sphere((3 * R * k, 0, 0), R, material=mat)
                                    for k in range(4)]))
    weight_contacts(ids, np.array([0.3, 0.7, 1.0, 1.0]))
    copies = [O.bodies[int(i)].material for i in ids[:2]]
    assert [m.label for m in copies] == [OWN_COPY] * 2 and copies[0].id != copies[1].id
    assert [m.young for m in copies] == [30e9 * 0.3, 30e9 * 0.7]
    count = len(O.materials)
    before, beta = np.array([0.3, 0.7, 1.0, 1.0]), np.array([1.0, 0.5, 0.4, 1.0])
    weight_contacts(ids, beta, before)
    young = [O.bodies[int(i)].material.young for i in ids]
    assert young == [30e9 * 0.3 * (1.0 / 0.3), 30e9 * 0.7 * (0.5 / 0.7), 30e9 * 0.4, 30e9]
    assert [O.bodies[int(i)].material.id for i in ids[:2]] == [m.id for m in copies]
    assert len(O.materials) == count + 1 and O.materials[mat].young == 30e9
