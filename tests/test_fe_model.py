"""ElasticModel: mass, stiffness, coupling operators, boundary conditions, stress.

Exact answers: totals of the lumped mass, rigid modes in the kernel of K, exact interpolation
of linear fields (any element shape), uniform stress states.
"""
import numpy as np
import pytest
import scipy.sparse as sp

from fenicsx_side.mesh import box_mesh, box_mesh_with_hole
from fenicsx_side.model import ElasticModel, face

E, NU, RHO = 31e9, 0.2, 2400.0
P0, P1, N = (0.0, 0.0, 0.0), (1.2, 1.0, 0.4), (6, 5, 2)
ROUND_OFF = 1e-12  # relative, for sums and products of a few hundred terms


def distorted_hex_mesh(seed=0):
    """Box hex mesh whose interior nodes moved by up to 0.25 element size: non-affine cells
    with warped faces, same outer boundary."""
    msh = box_mesh(P0, P1, N)
    x = msh.geometry.x
    size = (np.subtract(P1, P0) / N)
    interior = np.all((x > np.add(P0, 1e-9)) & (x < np.subtract(P1, 1e-9)), axis=1)
    rng = np.random.default_rng(seed)
    x[interior] += rng.uniform(-0.25, 0.25, (interior.sum(), 3)) * size
    return msh


MESHES = {
    "hex": lambda: box_mesh(P0, P1, N),
    "tet": lambda: box_mesh(P0, P1, N, "tetrahedron"),
    "distorted-hex": distorted_hex_mesh,
}


@pytest.fixture(scope="module", params=list(MESHES))
def model(request):
    return ElasticModel(MESHES[request.param](), E, NU, RHO)


def box_volume():
    return float(np.prod(np.subtract(P1, P0)))


def test_lumped_mass_totals_rho_volume(model):
    assert np.all(model.mass > 0)
    for c in range(3):
        assert model.mass[c::3].sum() == pytest.approx(RHO * box_volume(), rel=ROUND_OFF)


def test_lumped_mass_of_holed_box():
    m = ElasticModel(box_mesh_with_hole(P0, P1, N, (0.4, 0.4, 0.0), (0.8, 0.6, 0.4)), E, NU, RHO)
    assert m.mass[0::3].sum() == pytest.approx(RHO * (box_volume() - 0.4 * 0.2 * 0.4),
                                               rel=ROUND_OFF)


def test_nodes_follow_the_blocked_dof_layout(model):
    assert model.ndof == 3 * len(model.nodes) == model.K.shape[0] == model.K.shape[1]
    assert model.nodes.shape == (model.ndof // 3, 3)


def test_rigid_motions_are_in_the_kernel_of_K(model):
    K = model.K
    assert abs(K - K.T).max() <= ROUND_OFF * abs(K).max()
    scale = abs(K).sum(axis=1).max()  # ‖K‖∞: bounds ‖K r‖∞ / ‖r‖∞
    w = np.array([0.3, -0.7, 0.5])
    for r in (np.tile([1.0, -2.0, 0.5], len(model.nodes)),   # translation
              np.cross(w, model.nodes - 0.5).ravel()):        # infinitesimal rotation w × x
        assert np.abs(K @ r).max() <= ROUND_OFF * scale * np.abs(r).max()


def axial(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def test_point_operators_exact_for_linear_fields(model):
    rng = np.random.default_rng(1)
    points = rng.uniform(P0, P1, (400, 3))
    points[:3] = [P0, P1, model.nodes[7]]  # box corners and a node: shared by several cells
    a, B = rng.normal(size=3), rng.normal(size=(3, 3))
    u = (a + model.nodes @ B.T).ravel()
    k, h = model.point_operators(points)
    assert k.shape == h.shape == (3 * len(points), model.ndof)
    assert sp.isspmatrix_csr(k) and sp.isspmatrix_csr(h)
    exact_u = a + points @ B.T
    assert np.abs((k @ u).reshape(-1, 3) - exact_u).max() <= ROUND_OFF * np.abs(exact_u).max()
    rotation = axial(0.5 * (B - B.T))
    assert np.abs((h @ u).reshape(-1, 3) - rotation).max() <= ROUND_OFF * np.abs(B).max()


def test_located_cells_contain_their_points(model):
    """Reference coordinates in the reference cell (the pull-back picks the right cell among
    the ones whose vertex hulls contain the point)."""
    points = np.random.default_rng(2).uniform(P0, P1, (400, 3))
    cells, X = model.locate(points)
    assert np.all(model._reference_excess(X) < 1e-12)
    N, _ = model._basis_at(cells, X)
    mapped = np.einsum("pi,pia->pa", N, model.nodes[model.cell_nodes[cells]])
    assert np.abs(mapped - points).max() < 1e-13


def test_point_outside_the_mesh_is_named(model):
    points = np.array([[0.5, 0.5, 0.2], [0.5, 0.5, 0.41], [2.0, 0.5, 0.2]])
    with pytest.raises(ValueError, match=r"point 1 at \[0.5, 0.5, 0.41\] is in no FE cell "
                                         r"\(2 of 3 points"):
        model.point_operators(points)
    with pytest.raises(ValueError, match=r"point 1 at \[0.5, 0.5, 0.41\] is in no FE cell"):
        model.check_covered(points)
    model.check_covered(points[:1])


def test_normal_only_dirichlet_faces():
    m = ElasticModel(box_mesh(P0, P1, N), E, NU, RHO,
                     dirichlet=[(face(2, P0[2]), (2,)), (face(0, P1[0]), (0,))])
    on_bottom = np.isclose(m.nodes[:, 2], P0[2])
    on_right = np.isclose(m.nodes[:, 0], P1[0])
    expected = np.zeros((len(m.nodes), 3), bool)
    expected[on_bottom, 2] = True
    expected[on_right, 0] = True
    assert np.array_equal(m.fixed.reshape(-1, 3), expected)
    m.f_ext = np.tile([1.0, 2.0, -3.0], len(m.nodes)) * m.mass  # a uniform body force
    dt = 0.5 * m.critical_dt()
    for _ in range(50):
        m.predict(dt)
    u = m.u.reshape(-1, 3)
    assert np.all(m.u[m.fixed] == 0) and np.all(m.v[m.fixed] == 0)
    assert np.all(u[on_bottom & ~on_right][:, :2] != 0) and np.all(u[on_bottom][:, 1] != 0)
    assert np.all(u[on_right & ~on_bottom][:, 1:] != 0) and np.all(u[on_right][:, 1] != 0)
    assert m.t == pytest.approx(50 * dt, rel=1e-14)


def test_held_nodes_of_an_inner_plane_cut_the_load_path():
    """A box of two halves, its nodes on the inner plane x = 0.6 held in every component: a
    uniform body force on the right half alone moves no node of the left half (exactly, to
    round-off), and dynamics keeps the held nodes still. Held on its end planes instead (what
    moved there is set still), it is the model held by Dirichlet faces there, dof for dof."""
    from cases.slab.bending import _static_solve
    from fenicsx_side.mesh import tensor_box_with_hole
    xs, ys, zs = np.linspace(0, 1.2, 7), np.linspace(0, 1.0, 6), np.linspace(0, 0.4, 3)
    m = ElasticModel(tensor_box_with_hole(xs, ys, zs), E, NU, RHO)
    x = m.nodes[:, 0]
    m.hold(np.isclose(x, 0.6), (0, 1, 2))
    f = np.where(np.repeat(x > 0.6 + 1e-9, 3), np.tile([0.0, 1.0, -3.0], len(x)), 0.0) * m.mass
    free = np.flatnonzero(~m.fixed)
    u = np.zeros(m.ndof)
    u[free] = _static_solve(m.K, free, f[free])
    u = u.reshape(-1, 3)
    assert np.abs(u[x < 0.6 + 1e-9]).max() < 1e-12 * np.abs(u).max()
    assert np.all(np.abs(u[x > 0.6 + 1e-9, 2]) > 0)
    m.f_ext = f
    for _ in range(20):
        m.predict(0.5 * m.critical_dt())
    assert np.all(m.u[m.fixed] == 0) and np.all(m.v[m.fixed] == 0)
    ends = ElasticModel(tensor_box_with_hole(xs, ys, zs), E, NU, RHO)
    ends.u = ends.v = np.ones(ends.ndof)
    ends.hold(np.isclose(x, 0.0) | np.isclose(x, 1.2), (2,))
    assert np.all(ends.u[ends.fixed] == 0) and np.all(ends.v[ends.fixed] == 0)
    assert np.all(ends.u[~ends.fixed] == 1)
    faces = ElasticModel(box_mesh(P0, P1, N), E, NU, RHO,
                         dirichlet=[(face(0, 0.0), (2,)), (face(0, 1.2), (2,))])
    assert np.array_equal(ends.nodes, faces.nodes)
    assert np.array_equal(ends.fixed, faces.fixed)
    with pytest.raises(ValueError, match="component 3"):
        ends.hold([0], (3,))


def test_bad_dirichlet_is_named():
    msh = box_mesh(P0, P1, N)
    with pytest.raises(ValueError, match="condition 1: its locator matches no boundary facet"):
        ElasticModel(msh, E, NU, RHO, dirichlet=[(face(2, 0.0), (2,)), (face(2, 0.2), (2,))])
    with pytest.raises(ValueError, match="component 3"):
        ElasticModel(msh, E, NU, RHO, dirichlet=[(face(2, 0.0), (3,))])


def test_predict_and_correct_are_central_differences():
    m = ElasticModel(box_mesh(P0, P1, N), E, NU, RHO, dirichlet=[(face(2, 0.0), (0, 1, 2))])
    rng = np.random.default_rng(3)
    free = ~m.fixed
    u0, v0, f = (np.where(free, rng.normal(size=m.ndof), 0.0) for _ in range(3))
    m.u, m.v, m.f_ext = u0 * 1e-6, v0, f
    dt = 1e-6
    m.predict(dt)
    v1 = np.where(free, v0 + dt * (f - m.K @ (u0 * 1e-6)) / m.mass, 0.0)
    assert np.allclose(m.v, v1, rtol=0, atol=ROUND_OFF * np.abs(v1).max())
    assert np.allclose(m.u, u0 * 1e-6 + dt * v1, rtol=0, atol=ROUND_OFF * 1e-6 * np.abs(u0).max())
    dofs, du = np.flatnonzero(free)[:10], rng.normal(size=10) * 1e-7
    u1, v1 = m.u.copy(), m.v.copy()
    m.correct(dofs, du, dt)
    assert np.array_equal(m.u[dofs], u1[dofs] + du) and np.array_equal(m.v[dofs], v1[dofs] + du / dt)
    with pytest.raises(ValueError, match="that dof is fixed"):
        m.u = np.ones(m.ndof)


@pytest.mark.parametrize("mesh_name", list(MESHES))
def test_uniaxial_stress_state(mesh_name):
    """u = B x with ε = diag(1, −ν, −ν) s/E is the uniaxial stress σ = diag(s, 0, 0)."""
    m = ElasticModel(MESHES[mesh_name](), E, NU, RHO)
    s = -25e6
    B = np.diag([1.0, -NU, -NU]) * s / E
    m.u = (m.nodes @ B.T).ravel()
    st = m.stress()
    assert st.tensor.shape == (len(m.cell_nodes), 3, 3)
    assert np.abs(st.tensor - np.diag([s, 0.0, 0.0])).max() <= ROUND_OFF * abs(s)
    assert np.allclose(st.von_mises, abs(s), rtol=ROUND_OFF, atol=0)
    assert np.abs(st.max_principal).max() <= ROUND_OFF * abs(s)  # the two zero principal values
    assert m.strain_energy() == pytest.approx(0.5 * s ** 2 / E * box_volume(), rel=1e-10)
