"""Embedded bars in the FE model (fenicsx_side.bars) against exact answers: a linear
displacement field is interpolated exactly at any point of the mesh, so an embedded bar
stretched by it stores exactly ½ (EA/L) Δ²; rigid motions strain no bar; the lumped mass gains
exactly ρ_s A L."""
import numpy as np
import pytest

from cases.reinforcement import Layer, bar_layout
from fenicsx_side.bars import EmbeddedBars
from fenicsx_side.mesh import box_mesh
from fenicsx_side.model import ElasticModel
from test_fe_model import MESHES, P0, P1

E, NU, RHO = 31e9, 0.2, 2400.0
ROUND_OFF = 1e-11   # relative, sums of a few thousand products


def oblique_bars():
    """Two bars not aligned with the mesh, ends inside cells (no node is on a bar)."""
    from cases.reinforcement import Bars
    start = np.array([[0.13, 0.11, 0.07], [1.07, 0.21, 0.33]])
    end = np.array([[1.01, 0.87, 0.29], [0.17, 0.93, 0.09]])
    n = len(start)
    return Bars(start, end, np.array([0.012, 0.016]), np.full(n, 200e9), np.full(n, 500e6),
                np.full(n, 7850.0), np.full(n, np.nan), np.arange(n))


@pytest.fixture(params=list(MESHES))
def mesh_name(request):
    return request.param


def linear_field(model, B, a=(0.0, 0.0, 0.0)):
    """u = a + B x at the model's nodes, over global dofs (serial: local = global)."""
    return (np.asarray(a) + model.nodes @ np.asarray(B).T).ravel()


def test_bar_in_a_linear_field_stores_ea_over_l(mesh_name):
    """u = B x: every element of a bar of axis t has strain tᵀ B t, so N = E A tᵀ B t and the
    bars' energy ½ uᵀ Pᵀ K_b P u = Σ ½ (EA/L) (tᵀ B t L)² — the stiffness EA/L of each bar."""
    model = ElasticModel(MESHES[mesh_name](), E, NU, RHO)
    bars = oblique_bars()
    fe = EmbeddedBars(model, bars, element_length=0.05)
    B = np.array([[2e-4, 1e-4, -3e-5], [5e-5, -1e-4, 2e-5], [1e-5, 4e-5, 3e-4]])
    u = linear_field(model, B, a=(1e-3, -2e-3, 5e-4))
    strain = np.einsum("bi,ij,bj->b", bars.axis, B, bars.axis)
    exact = np.sum(bars.young * bars.area / bars.length * (strain * bars.length) ** 2)
    assert u @ (fe.stiffness @ u) == pytest.approx(exact, rel=ROUND_OFF)
    assert fe.axial_force(u) == pytest.approx((bars.young * bars.area * strain)[fe.bar],
                                              rel=ROUND_OFF)


def test_embedded_bar_adds_ea_over_l_to_the_block():
    """K after add_to − K of the block alone = the bars' stiffness, so in a uniaxial field
    u = ε x e_x the model's energy grows by exactly (EA/L)(ε L_x)² / 2 per bar along x."""
    model = ElasticModel(box_mesh(P0, P1, (6, 5, 2)), E, NU, RHO)
    bars = bar_layout([Layer(diameter=0.016, spacing=0.3, direction="x", cover=0.05)],
                      P0, P1)
    before = model.K.copy()
    fe = EmbeddedBars(model, bars, element_length=0.07)
    fe.add_to(model)
    eps = 1e-4
    u = linear_field(model, np.diag([eps, 0, 0]))
    added = u @ (model.K @ u) - u @ (before @ u)
    exact = np.sum(bars.young * bars.area / bars.length * (eps * bars.length) ** 2)
    assert added == pytest.approx(exact, rel=1e-9)   # difference of energies ~30 × larger
    # predict multiplies by the PETSc matrix: it must hold the same K
    model.u = u
    model.v = np.zeros(model.ndof)
    model.predict(1e-12)
    force = model.v / 1e-12 * model.mass
    assert np.allclose(force, -(model.K @ u), rtol=0, atol=1e-9 * np.abs(model.K @ u).max())


def test_rigid_motion_strains_no_bar(mesh_name):
    """u = a + ω × x: t·(u_b − u_a) = t·(ω × (x_b − x_a)) = 0 for x_b − x_a ∥ t."""
    model = ElasticModel(MESHES[mesh_name](), E, NU, RHO)
    fe = EmbeddedBars(model, oblique_bars(), element_length=0.05)
    w = np.array([1e-3, -2e-3, 5e-4])
    spin = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    u = linear_field(model, spin, a=(1e-3, 2e-3, -1e-3))
    scale = np.abs(fe.young * fe.area).max() * np.abs(w).max()
    assert np.abs(fe.axial_force(u)).max() < ROUND_OFF * scale
    Ku = fe.stiffness @ u
    assert np.abs(Ku).max() < ROUND_OFF * abs(fe.stiffness).max() * np.abs(u).max() * 100


def test_bars_add_their_mass_exactly(mesh_name):
    model = ElasticModel(MESHES[mesh_name](), E, NU, RHO)
    bars = oblique_bars()
    before = model.mass.copy()
    EmbeddedBars(model, bars, element_length=0.05).add_to(model)
    for c in range(3):
        assert (model.mass - before)[c::3].sum() == pytest.approx(bars.mass(), rel=ROUND_OFF)
    assert np.all(model.mass >= before)


def three_point_bending_deflection(bars_layer, n=(112, 2, 8), span=2.8, width=0.2, depth=0.28,
                                   load=1e5):
    """Static mid-span deflection (bottom face) of a simply supported strip, line supports
    along y at the bottom edges, line load at mid-span on top; bars embedded if given."""
    import scipy.sparse.linalg as spla
    model = ElasticModel(box_mesh((0, 0, 0), (span, width, depth), n), E, NU, RHO)
    bars = None
    if bars_layer is not None:
        bars = bar_layout([bars_layer], (0, 0, 0), (span, width, depth))
        EmbeddedBars(model, bars, element_length=span / n[0] / 2).add_to(model)
    x, tol = model.nodes, 1e-9
    on = lambda px, pz: (np.abs(x[:, 0] - px) < tol) & (np.abs(x[:, 2] - pz) < tol)
    left, right = on(0, 0), on(span, 0)
    fixed = np.zeros(model.ndof, bool)
    fixed[3 * np.flatnonzero(left | right) + 2] = True     # supports
    fixed[3 * np.flatnonzero(left)] = True                 # x and y rigid motions
    fixed[3 * np.flatnonzero(left)[0] + 1] = True
    top = np.flatnonzero(on(span / 2, depth))
    edge = (np.abs(x[top, 1]) < tol) | (np.abs(x[top, 1] - width) < tol)
    share = np.where(edge, 0.5, 1.0)                        # a uniform line load on Q1 edges
    f = np.zeros(model.ndof)
    f[3 * top + 2] = -load * share / share.sum()
    free = np.flatnonzero(~fixed)
    u = np.zeros(model.ndof)
    u[free] = spla.spsolve(model.K.tocsc()[free][:, free], f[free])
    return -u[3 * np.flatnonzero(on(span / 2, 0)) + 2].mean(), bars


def test_reinforced_strip_in_three_point_bending_matches_the_transformed_section():
    """δ = P L³/(48 E_c I_t) + P L/(4 κ G A) (Timoshenko, κ = 5/6), I_t of the uncracked
    transformed section (cases.reinforcement.transformed_section): the FE strip with 3 bars of
    20 mm (ρ = 1.7 %) within 10 %, as is the plain strip with I = b h³/12."""
    from cases.reinforcement import transformed_section
    span, width, depth, load = 2.8, 0.2, 0.28, 1e5
    shear = load * span / (4 * 5 / 6 * E / (2 * (1 + NU)) * width * depth)
    plain, _ = three_point_bending_deflection(None)
    layer = Layer(diameter=0.02, spacing=0.05, direction="x", cover=0.04)
    reinforced, bars = three_point_bending_deflection(layer)
    _, inertia = transformed_section(width, depth, E, np.full(len(bars), depth - 0.04),
                                     bars.area, 200e9)
    assert plain == pytest.approx(load * span**3 / (48 * E * width * depth**3 / 12) + shear,
                                  rel=0.1)
    assert reinforced == pytest.approx(load * span**3 / (48 * E * inertia) + shear, rel=0.1)
    assert reinforced < 0.9 * plain        # the bars do stiffen it (formula: 0.889)
