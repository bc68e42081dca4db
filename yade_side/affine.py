"""The elastic stiffness of a packing's cohesive links under an affine strain, and the
stiffnesses the CPM law gives a link (numpy only: no YADE needed).

Under a uniform strain ε every link of rest length L and normal n (spheres turning with the
strain's rotation, none for a symmetric ε) is stretched by L n·ε·n and sheared by
L (ε n − (n·ε·n) n): its elastic energy is ½ kn L² (n·ε·n)² + ½ ks L² |ε n − (n·ε·n) n|².
Summed over the links of a volume V, that is ½ V ε : C : ε with C the affine stiffness. A
packing's own response relaxes below it (its spheres move off the affine field), so C is an
upper bound of the links' energy at that strain; it is what links made at the positions of an
FE field's strain hold (orchestrator/run/grow.py), and against the FE's C it bounds the
links' energy over the cells' (docs/auto-zone.md, "The links' energy at a conversion").

Tensors are 6 × 6 in Mandel notation: e = (ε11, ε22, ε33, √2 ε23, √2 ε13, √2 ε12), so that
ε : C : ε = e · C e.
"""
import numpy as np

_S2 = np.sqrt(2.0)


def link_stiffness(r1, r2, length, young, shear):
    """Cross-section, kn and ks the CPM law gives a cohesive link between spheres of radii r1,
    r2 at rest length `length`, of contact moduli E = `young` and G = `shear` (CpmMat's
    poisson × young): A = π min(r1, r2)², kn = E A / L, ks = G A / L (arrays)."""
    section = np.pi * np.minimum(r1, r2) ** 2
    return section, section * young / length, section * shear / length


def normal_row(n):
    """(m, 6): the Mandel row b with n·ε·n = b · e for each unit normal of n (m, 3)."""
    return np.column_stack([n[:, 0] ** 2, n[:, 1] ** 2, n[:, 2] ** 2, _S2 * n[:, 1] * n[:, 2],
                            _S2 * n[:, 0] * n[:, 2], _S2 * n[:, 0] * n[:, 1]])


def shear_rows(n):
    """(m, 3, 6): T with ε n − (n·ε·n) n = T e for each unit normal of n (m, 3)."""
    m = len(n)
    grad = np.zeros((m, 3, 6))          # ε n: row i, Mandel column of ε_ij × n_j
    for i in range(3):
        grad[:, i, i] = n[:, i]
    s = n / _S2                          # off-diagonal ε_ij = e_k / √2
    grad[:, 1, 3], grad[:, 2, 3] = s[:, 2], s[:, 1]     # ε23
    grad[:, 0, 4], grad[:, 2, 4] = s[:, 2], s[:, 0]     # ε13
    grad[:, 0, 5], grad[:, 1, 5] = s[:, 1], s[:, 0]     # ε12
    return grad - n[:, :, None] * normal_row(n)[:, None, :]


def affine_stiffness(centres, radii, pairs, young, poisson, volume, shear=True):
    """C (6, 6) of the links `pairs` ((m, 2) indices into centres, radii) over `volume`, their
    rest lengths the centres' distances, their kn and ks link_stiffness's; with shear=False the
    normal springs alone (what a conversion writes by default: docs/auto-zone.md); `poisson`:
    CpmMat's, G / E of the links."""
    axis = centres[pairs[:, 1]] - centres[pairs[:, 0]]
    length = np.linalg.norm(axis, axis=1)
    n = axis / length[:, None]
    _, kn, ks = link_stiffness(radii[pairs[:, 0]], radii[pairs[:, 1]], length, young,
                               poisson * young)
    b = normal_row(n)
    C = np.einsum("m,mi,mj->ij", kn * length ** 2, b, b)
    if shear:
        T = shear_rows(n)
        C += np.einsum("m,mki,mkj->ij", ks * length ** 2, T, T)
    return C / volume


def isotropic_stiffness(young, nu):
    """C (6, 6) of an isotropic solid of modulus `young` and Poisson's ratio `nu`."""
    lam = young * nu / ((1 + nu) * (1 - 2 * nu))
    mu = young / (2 * (1 + nu))
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[np.diag_indices(6)] += 2 * mu
    return C


def energy_ratio_bounds(C, C_ref):
    """(least, largest) of e·C e / e·C_ref e over every strain e: the generalised eigenvalues
    of C against the positive definite C_ref."""
    from scipy.linalg import eigh
    values = eigh(C, C_ref, eigvals_only=True)
    return float(values[0]), float(values[-1])
