"""The links' affine stiffness (yade_side.affine) against exact answers: a simple cubic lattice
of axial links, the Cauchy relations of central springs, an isotropic solid."""
import numpy as np
import pytest

from yade_side.affine import (affine_stiffness, energy_ratio_bounds, isotropic_stiffness,
                              normal_row, shear_rows)

E, NU_CPM, R = 30e9, 0.2, 0.01
EPS = np.finfo(float).eps


def cubic_lattice(k):
    """k³ spheres of radius R on a simple cubic lattice of spacing 2R, linked to their six
    axial neighbours only; the volume is the lattice's periodic cell × k³."""
    i = np.indices((k, k, k)).reshape(3, -1).T
    centres = 2 * R * i.astype(float)
    index = lambda ijk: np.ravel_multi_index(ijk.T, (k, k, k))
    pairs = [np.column_stack([index(i[i[:, a] < k - 1]),
                              index(i[i[:, a] < k - 1] + np.eye(3, dtype=int)[a])])
             for a in range(3)]
    return centres, np.full(len(centres), R), np.vstack(pairs), (2 * R * k) ** 3


def test_the_rows_give_the_normal_and_tangential_strain_of_any_strain():
    rng = np.random.default_rng(1)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    eps = rng.normal(size=(3, 3))
    eps = eps + eps.T
    e = np.r_[np.diag(eps), np.sqrt(2) * np.array([eps[1, 2], eps[0, 2], eps[0, 1]])]
    en = np.einsum("ij,mj->mi", eps, n)
    nen = np.einsum("mi,mi->m", n, en)
    assert normal_row(n) @ e == pytest.approx(nen, rel=1e-13, abs=1e-13)
    assert np.einsum("mij,j->mi", shear_rows(n), e) == pytest.approx(
        en - nen[:, None] * n, rel=1e-13, abs=1e-13)


def test_a_cubic_lattice_of_axial_links():
    """Per periodic cell (2R)³ one link along each axis, kn = E π R² / 2R, ks = ν kn: the
    affine C11 = kn L² / (2R)³ = π E / 4, C12 = 0, and the Mandel shear term C66 = π ν E / 4
    (two links sheared by L ε12 each). A finite lattice has k − 1 links per row of k spheres."""
    k = 6
    centres, radii, pairs, volume = cubic_lattice(k)
    C = affine_stiffness(centres, radii, pairs, E, NU_CPM, volume) * k / (k - 1)
    exact = np.zeros((6, 6))
    exact[np.diag_indices(3)] = np.pi * E / 4
    exact[np.arange(3, 6), np.arange(3, 6)] = np.pi * NU_CPM * E / 4
    assert C == pytest.approx(exact, rel=1e-12, abs=1e-12 * E)
    normal = affine_stiffness(centres, radii, pairs, E, NU_CPM, volume, shear=False)
    assert normal[3:, 3:] == pytest.approx(np.zeros((3, 3)), abs=1e-12 * E)


def test_central_springs_obey_the_cauchy_relations():
    """With normal springs alone C_ijkl is fully symmetric (a sum of n⊗n⊗n⊗n): C1122 = C1212,
    i.e. in Mandel form C[0, 1] = C[5, 5] / 2, for any packing."""
    rng = np.random.default_rng(2)
    centres = rng.uniform(0, 0.2, size=(400, 3))
    radii = rng.uniform(0.8, 1.2, size=400) * R
    pairs = np.column_stack([np.arange(399), np.arange(1, 400)])
    C = affine_stiffness(centres, radii, pairs, E, NU_CPM, 0.008, shear=False)
    for (a, b), (c, d) in (((0, 1), (5, 5)), ((0, 2), (4, 4)), ((1, 2), (3, 3))):
        assert C[a, b] == pytest.approx(C[c, d] / 2, rel=1e3 * EPS)


def test_an_isotropic_solid_against_itself_and_its_moduli():
    """Energy ratio bounds of C against itself: (1, 1); of 2 C: (2, 2); uniaxial strain gives
    λ + 2μ, shear strain 2μ (Mandel)."""
    C = isotropic_stiffness(E, 0.25)
    lam, mu = E * 0.25 / (1.25 * 0.5), E / 2.5
    assert C[0, 0] == pytest.approx(lam + 2 * mu, rel=1e-15)
    assert C[5, 5] == pytest.approx(2 * mu, rel=1e-15)
    assert energy_ratio_bounds(C, C) == pytest.approx((1, 1), rel=1e-12)
    assert energy_ratio_bounds(2 * C, C) == pytest.approx((2, 2), rel=1e-12)


def test_the_slabs_links_against_its_fe():
    """`python3 -m cases.slab.link_energy` on the small slab: shear springs add a positive
    semi-definite term, so neither bound of the energy ratio falls when they are counted."""
    from cases.slab.link_energy import measure
    m = measure("small")
    assert m["links"] > 5 * m["spheres"]
    for where in ("slab", "interior"):
        normal, both = m[f"{where}_normal"], m[f"{where}_normal_and_shear"]
        for key in ("vs_fe", "vs_packing"):
            assert normal[key][0] <= normal[key][1]
            assert both[key][0] >= normal[key][0] and both[key][1] >= normal[key][1]
