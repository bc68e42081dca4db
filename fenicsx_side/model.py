"""Linear-elastic, small-strain, lumped-mass explicit FE model (vector P1) on a dolfinx mesh.

The state lives in numpy arrays over the dofs this rank owns (all of them in serial); the
stiffness is applied by PETSc, so the same model runs distributed under MPI (see
fenicsx_side.distributed for driving it from one rank). Dof layout is dolfinx's blocked one:
dof = 3 * node + component, in the rank's local numbering; `global_dofs` maps it to the
global numbering that point_operators' columns use.
"""
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

import ufl
from dolfinx import fem, geometry
from dolfinx.fem import petsc
from dolfinx.mesh import locate_entities_boundary
from mpi4py import MPI
from petsc4py import PETSc
from slepc4py import SLEPc

# relative accuracy asked of the largest eigenvalue in critical_dt
_EIG_TOL = 1e-10
# Newton pull-back to reference coordinates: step size (reference units) that ends it
_PULL_BACK_TOL = 1e-13
_PULL_BACK_ITERATIONS = 30


def face(axis, value, tol=1e-8):
    """Locator of the plane x[axis] = value (absolute tolerance tol), for `dirichlet`."""
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    return lambda x: np.abs(x[axis] - value) <= tol


@dataclass
class CellStress:
    tensor: np.ndarray         # (n_cells, 3, 3) cell-average Cauchy stress
    von_mises: np.ndarray      # (n_cells,)
    max_principal: np.ndarray  # (n_cells,) largest principal stress (tension > 0)


class ElasticModel:
    """Explicit central-difference (leap-frog) linear elastic model.

    dirichlet: sequence of (locator, components); locator(x) -> bool mask over the columns of
    x (3, n), applied to boundary facets as dolfinx's locate_entities_boundary does;
    components: indices (0, 1, 2) held at zero on those facets.
    State: u = displacement at time t, v = velocity at t - dt/2 (half step, like YADE's
    NewtonIntegrator). Assigning u or v copies into the model's buffers.

    Attributes (over the dofs and cells this rank owns; in serial, all of them): ndof;
    nodes (ndof/3, 3), node of dof 3 i + c is i; cell_nodes (n_cells, 4 or 8) local node
    indices, ghost nodes after the owned ones; mass (ndof,) lumped row sums; K scipy csr copy of
    the owned rows of the stiffness, global columns (predict multiplies by the same PETSc
    matrix, which is faster; neither has Dirichlet rows); fixed (ndof,) bool; f_ext (ndof,)
    external nodal force; t; comm; global_dofs (ndof,) and ndof_global.
    """

    def __init__(self, msh, E, nu, rho, dirichlet=(), quadrature_degree=2, weight=None):
        if msh.geometry.cmap.degree != 1:
            raise ValueError(f"need an affine/multilinear mesh geometry, got degree "
                             f"{msh.geometry.cmap.degree}")
        if not E > 0 or not rho > 0 or not -1.0 < nu < 0.5:
            raise ValueError(f"need E > 0, rho > 0 and -1 < nu < 0.5; got E={E!r}, nu={nu!r}, "
                             f"rho={rho!r}")
        self.msh = msh
        self.comm = msh.comm
        self.E, self.nu, self.rho = float(E), float(nu), float(rho)
        self.mu = E / (2 * (1 + nu))
        self.lmbda = E * nu / ((1 + nu) * (1 - 2 * nu))
        self.V = fem.VectorFunctionSpace(msh, ("Lagrange", 1))
        self.dx = ufl.dx(domain=msh, metadata={"quadrature_degree": quadrature_degree})

        self.basis = self.V.element.basix_element  # scalar P1, also the geometry's element
        index_map = self.V.dofmap.index_map
        owned = index_map.size_local
        self._local_nodes = self.V.tabulate_dof_coordinates()  # owned nodes, then ghosts
        self.nodes = self._local_nodes[:owned]
        self.ndof = 3 * owned
        self.ndof_global = 3 * index_map.size_global
        self._global_node = index_map.local_to_global(
            np.arange(len(self._local_nodes), dtype=np.int32))
        self.global_dofs = (3 * self._global_node[:owned, None] + np.arange(3)).ravel()
        n_cells = msh.topology.index_map(msh.topology.dim).size_local
        self.cell_nodes = self.V.dofmap.list.array.reshape(-1, self.basis.dim)[:n_cells]

        u, w = ufl.TrialFunction(self.V), ufl.TestFunction(self.V)
        # weight(x) (points (n, 3) -> (n,), > 0): the model of the weighted energy α H_FE, with
        # K = ∫ α ε:C:ε and m = ∫ α ρ N (symmetric: the bridging weights stay conservative)
        a = 1.0 if weight is None else self._interpolated(weight)
        stiffness = fem.form(a * ufl.inner(self._sigma(u), _eps(w)) * self.dx)
        assembled = petsc.assemble_matrix(stiffness)
        assembled.assemble()
        indptr, indices, data = assembled.getValuesCSR()
        self.K = sp.csr_matrix((data, indices, indptr), shape=(self.ndof, self.ndof_global))
        self._K_petsc = self._operator(self.K)
        ones = fem.Constant(msh, PETSc.ScalarType((1.0, 1.0, 1.0)))
        mass = petsc.assemble_vector(fem.form(a * rho * ufl.inner(ones, w) * self.dx))
        mass.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.mass = mass.array.copy()
        bad = np.flatnonzero(~(self.mass > 0))
        if bad.size:
            raise ValueError(f"lumped mass of dof {bad[0]} (node at {self.nodes[bad[0] // 3]}) is "
                             f"{self.mass[bad[0]]!r}: an element is inverted or badly distorted")

        self.fixed = self._dirichlet_mask(dirichlet)
        self.dominant_mode = None      # of M^-½ K M^-½, once critical_dt found it
        # zero inverse mass freezes the fixed dofs in predict()
        self._inv_mass_free = np.where(self.fixed, 0.0, 1.0 / self.mass)
        self.f_ext = np.zeros(self.ndof)
        self._u, self._v = np.zeros(self.ndof), np.zeros(self.ndof)
        self._work = np.zeros(self.ndof)
        # PETSc views of the numpy buffers: K.mult (block matrix) is 2.8 × faster than scipy's
        # csr mat-vec at paper scale
        self._u_vec, self._work_vec = (PETSc.Vec().createWithArray(
            a, size=(self.ndof, PETSc.DECIDE), comm=self.comm) for a in (self._u, self._work))
        self.t = 0.0
        self._tree = None
        self._stress_op = None
        # members with a state of their own beyond K (fenicsx_side.bars: yielding steel)
        self.members = []

    # --- state -------------------------------------------------------------------------------
    @property
    def u(self):
        return self._u

    @u.setter
    def u(self, value):
        self._u[:] = self._checked_state("u", value)

    @property
    def v(self):
        return self._v

    @v.setter
    def v(self, value):
        self._v[:] = self._checked_state("v", value)

    def _checked_state(self, name, value):
        value = np.asarray(value, float).reshape(self.ndof)
        bad = np.flatnonzero(self.fixed & (value != 0))
        if bad.size:
            raise ValueError(f"{name}[{bad[0]}] = {value[bad[0]]!r} but that dof is fixed (zero)")
        return value

    def hold(self, nodes, components):
        """Hold `components` (of 0, 1, 2) of the owned `nodes` (indices or a mask over
        `nodes`) at zero from now on (their displacement and velocity set to zero), besides
        the Dirichlet facets: e.g. the nodes of a plane inside the mesh, which no boundary
        locator reaches."""
        bad = [c for c in components if c not in (0, 1, 2)]
        if bad:
            raise ValueError(f"hold: component {bad[0]!r} not in (0, 1, 2)")
        index = np.arange(len(self.nodes))[nodes]
        for c in components:
            self.fixed[3 * index + c] = True
        self._u[self.fixed] = self._v[self.fixed] = 0.0
        self._inv_mass_free = np.where(self.fixed, 0.0, 1.0 / self.mass)

    def add_stiffness_and_mass(self, stiffness, mass, member=None):
        """Add members that the mesh does not conform to (fenicsx_side.bars): `stiffness`, a
        sparse (ndof_global, ndof_global) matrix over global dofs, to K, and `mass`
        (ndof_global,) to the lumped mass. Each rank adds its owned rows. A `member` with a
        state of its own corrects the force K u each step (serial only): update(u),
        add_force(force), energy_correction(u), history(), restore_history(h)."""
        if member is not None:
            if self.comm.size > 1:
                raise ValueError("FE members with a state of their own (yielding bars) run "
                                 "on one rank")
            self.members.append(member)
        add = sp.csr_matrix(stiffness)[self.global_dofs]
        self.K = (self.K + add).tocsr()
        self._K_petsc = self._operator(self.K)
        self.mass = self.mass + np.asarray(mass, float)[self.global_dofs]
        self._inv_mass_free = np.where(self.fixed, 0.0, 1.0 / self.mass)
        self._stress_op = None

    def _operator(self, K):
        """K (owned rows, global columns) as PETSc's block matrix of the nodes' 3 × 3 blocks:
        its mat-vec reads one column index per block, 3.6 × faster than the scalar one at
        paper scale (27,054 dofs, docs/performance.md section 6)."""
        B = K.tobsr(blocksize=(3, 3))
        B.sort_indices()
        op = PETSc.Mat().createBAIJ(
            size=((self.ndof, self.ndof_global), (self.ndof, self.ndof_global)), bsize=3,
            csr=(B.indptr.astype(PETSc.IntType), B.indices.astype(PETSc.IntType),
                 B.data.ravel()), comm=self.comm)
        op.assemble()
        return op

    # --- time stepping ----------------------------------------------------------------------
    def predict(self, dt):
        """One central-difference step without coupling: v += dt M⁻¹(f_ext − K u); u += dt v."""
        self._K_petsc.mult(self._u_vec, self._work_vec)
        self._members_force(self._work)
        self._advance(self._work, dt)

    def _members_force(self, force):
        """The members' state at u, then their corrections of the internal force."""
        for member in self.members:
            member.update(self._u)
            member.add_force(force)

    def _advance(self, force, dt):
        """v += dt M⁻¹(f_ext − force); u += dt v (force, the internal force, is overwritten)."""
        np.subtract(self.f_ext, force, out=force)
        force *= self._inv_mass_free
        force *= dt
        self._v += force
        self._u += dt * self._v
        self.t += dt

    def correct(self, dofs, du, dt):
        """Add du to u[dofs] (unique dofs) and du/dt to v[dofs]: still a central difference."""
        self._u[dofs] += du
        self._v[dofs] += du / dt

    @property
    def distributed(self):
        """The state is spread over several MPI ranks."""
        return self.comm.size > 1

    def critical_dt(self, start=None):
        """2/ω_max of M⁻¹K over the free dofs (lumped mass), from the largest eigenvalue of
        M^-½ K M^-½ (SLEPc's Krylov-Schur, collective), raised by its relative tolerance so
        that the step is not overestimated. Fixed dofs get a zero scale: eigenvalue 0.
        `start` (this rank's dofs): where the iteration starts, e.g. another model's
        `dominant_mode` on these nodes (a grown zone's FE: 2 iterations instead of 15); the
        mode found is kept in `dominant_mode`."""
        S = self._K_petsc.copy()
        scale = S.createVecLeft()
        scale.array[:] = np.where(self.fixed, 0.0, 1.0 / np.sqrt(self.mass))
        S.diagonalScale(scale, scale)
        eps = SLEPc.EPS().create(self.comm)
        eps.setOperators(S)
        eps.setProblemType(SLEPc.EPS.ProblemType.HEP)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
        eps.setTolerances(_EIG_TOL, 1000)
        if start is not None and np.any(start[~self.fixed] != 0):
            v0 = S.createVecLeft()
            v0.array[:] = start
            eps.setInitialSpace([v0])
        eps.solve()
        if eps.getConverged() < 1:
            raise RuntimeError("critical_dt: the largest eigenvalue did not converge")
        mode = S.createVecLeft()
        lam = eps.getEigenpair(0, mode).real
        self.dominant_mode = mode.array.copy()
        return 2.0 / np.sqrt(lam * (1 + _EIG_TOL))

    def critical_dt_bound(self):
        """A lower bound of critical_dt without an eigensolve: by Gershgorin's theorem the
        largest eigenvalue of M^-½ K M^-½ (fixed dofs scaled out, as there) is at most its
        largest absolute row sum, s_i Σ_j |K_ij| s_j, s = 1/√m (0 on fixed dofs): one
        product with |K|, hundredths of a second at paper scale where SLEPc takes 0.12 s
        from a good start. Collective."""
        scale = np.zeros(self.ndof_global)
        for dofs, values in self.comm.allgather(
                (self.global_dofs, np.where(self.fixed, 0.0, 1.0 / np.sqrt(self.mass)))):
            scale[dofs] = values
        K = self.K
        absolute = sp.csr_matrix((np.abs(K.data), K.indices, K.indptr), K.shape, copy=False)
        rows = scale[self.global_dofs] * (absolute @ scale)
        return 2.0 / np.sqrt(self.comm.allreduce(rows.max(initial=0.0), op=MPI.MAX))

    # --- energies ---------------------------------------------------------------------------
    def kinetic_energy(self, weights=None):
        """½ Σ w m v² with the half-step velocity v(t − dt/2); weights per dof (default 1)."""
        w = 1.0 if weights is None else weights
        return self.comm.allreduce(float(np.sum(w * self.nodal_kinetic_energy())))

    def nodal_kinetic_energy(self):
        """½ m_i v_i² per owned dof, with the half-step velocity."""
        return 0.5 * self.mass * self._v ** 2

    def strain_energy(self, weights=None):
        """½ Σ w u (K u) at time t (nodal_strain_energy); weights per dof (default 1); and the
        members' part."""
        w = 1.0 if weights is None else weights
        return self.comm.allreduce(float(np.sum(w * self.nodal_strain_energy()))) + \
            self.members_energy()

    def nodal_strain_energy(self):
        """½ u_i (K u)_i per owned dof at time t, the members' part apart: they sum to
        ½ u·K u, but one dof's share can be negative."""
        Ku = self._K_petsc.createVecLeft()
        self._K_petsc.mult(self._u_vec, Ku)
        return 0.5 * self._u * Ku.array

    def members_energy(self):
        """What the members' state takes from ½ u·K u (their own energy, unweighted)."""
        return sum(m.energy_correction(self._u) for m in self.members)

    # --- history, for checkpoints (fenicsx_side.damaged adds its own) -----------------------
    carries_damage = False

    def history(self):
        """Arrays beyond u, v and t that the state needs (a name → array mapping)."""
        return {f"member{i}_{k}": v for i, m in enumerate(self.members)
                for k, v in m.history().items()}

    def restore_history(self, history):
        """Set what history() gave."""
        for i, m in enumerate(self.members):
            prefix = f"member{i}_"
            m.restore_history({k[len(prefix):]: v for k, v in history.items()
                               if k.startswith(prefix)})

    def take_state(self, old, nodes, cells):
        """Go on from the state of `old`, a model of the same grid whose nodes hold this
        one's (the FE part before its DE zone grew): nodes[i] is the node of `old` at this
        model's node i, cells[c] its cell at this model's cell c (the damage history's)."""
        if self.members or old.members or self.comm.size > 1:
            raise ValueError("an FE state moves to another mesh on one rank and without "
                             "members of their own (bars)")
        dofs = (3 * np.asarray(nodes)[:, None] + np.arange(3)).ravel()
        self.u, self.v, self.t = old.u[dofs], old.v[dofs], old.t

    def gradient_at(self, points):
        """∇u at `points` (n, 3, 3), [p, a, b] = ∂u_a/∂x_b (serial)."""
        cells, X = self.locate(points)
        grad = self._basis_at(cells, X)[1]                              # (n, nv, 3)
        nodal = self.u.reshape(-1, 3)[self.cell_nodes[cells]]           # (n, nv, 3)
        return np.einsum("pia,pib->pab", nodal, grad)

    # --- coupling operators -----------------------------------------------------------------
    def locate(self, points):
        """Cell containing each point and the point's reference coordinates in it: (cells, X).

        A point on a face shared by cells gets one of them. Raises ValueError naming the first
        point that is in no cell (serial: in no cell of the mesh; under MPI: in no cell this
        rank owns).
        """
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        found, cells, X = self._locate_owned(points)
        _check_located(found, points)
        return cells, X

    def covers(self, points):
        """Whether each point is in a cell of this rank's."""
        return self._locate_owned(np.ascontiguousarray(points, dtype=float).reshape(-1, 3))[0]

    def check_covered(self, points):
        """Raise ValueError naming the first point in no cell of the mesh (collective: the
        cells of every rank count)."""
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        self._owners(points, self._locate_owned(points)[0])

    def _owners(self, points, found):
        """The lowest rank owning a cell that holds each point (collective); ValueError if a
        point is in none."""
        size = self.comm.size
        owner = np.where(found, self.comm.rank, size).astype(np.int64)
        self.comm.Allreduce(MPI.IN_PLACE, owner, op=MPI.MIN)
        _check_located(owner < size, points)
        return owner

    def _locate_owned(self, points):
        """(found mask, cells, X) over the cells this rank owns; cells and X of the found
        points only."""
        if self._tree is None:
            self._tree = geometry.BoundingBoxTree(self.msh, self.msh.topology.dim)
        candidates = geometry.compute_collisions(self._tree, points)
        colliding = geometry.compute_colliding_cells(self.msh, candidates, points)
        pair_point = np.repeat(np.arange(len(points)), np.diff(colliding.offsets))
        pair_cell = colliding.array
        owned = pair_cell < len(self.cell_nodes)  # ghost cells are another rank's
        pair_point, pair_cell = pair_point[owned], pair_cell[owned]
        # Distorted hexahedra are located by their vertices' convex hull: keep, among the
        # colliding cells, the one whose reference coordinates are least outside the cell.
        X = self._pull_back(points[pair_point], pair_cell)
        miss = self._reference_excess(X)
        order = np.lexsort((miss, pair_point))
        first = order[np.flatnonzero(np.diff(pair_point[order], prepend=-1))]
        found = np.zeros(len(points), bool)
        found[pair_point[first]] = True
        return found, pair_cell[first], X[first]

    def point_operators(self, points):
        """(k, h), csr of shape (3n, ndof_global): k u = u(x_j); h u = ½ curl u (x_j)
        (docs/method.md). Columns are global dofs; under MPI each point is evaluated by the lowest
        rank owning a cell that contains it, and every rank gets the whole operators."""
        points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
        found, cells, X = self._locate_owned(points)
        owner = self._owners(points, found)
        mine = owner[found] == self.comm.rank
        cells, X = cells[mine], X[mine]
        n = len(points)
        N, grad = self._basis_at(cells, X)
        node = self._global_node[self.cell_nodes[cells]]        # (m, nv)
        j = np.broadcast_to(np.flatnonzero(found)[mine][:, None], node.shape)
        rows = [3 * j + c for c in range(3)]
        cols = [3 * node + c for c in range(3)]
        # ½ [g]× with g = ∇N_i(x_j): its 6 entries as (row a, column b, component of g, sign)
        cross = ((0, 1, 2, -1), (0, 2, 1, 1), (1, 0, 2, 1), (1, 2, 0, -1), (2, 0, 1, -1),
                 (2, 1, 0, 1))
        shape = (3 * n, self.ndof_global)
        k = self._gathered_csr([N] * 3, rows, cols, shape)
        h = self._gathered_csr([0.5 * sign * grad[:, :, g] for _, _, g, sign in cross],
                               [rows[a] for a, _, _, _ in cross],
                               [cols[b] for _, b, _, _ in cross], shape)
        return k, h

    def _gathered_csr(self, values, rows, cols, shape):
        """csr matrix from every rank's lists of equally shaped arrays of entries and indices."""
        flat = lambda arrays: np.concatenate([a.ravel() for a in arrays])
        parts = self.comm.allgather((flat(values), flat(rows), flat(cols)))
        v, r, c = (np.concatenate(p) for p in zip(*parts))
        return sp.csr_matrix((v, (r, c)), shape=shape)

    def _pull_back(self, points, cells):
        """Reference coordinates of points in the given cells (vectorised Newton iteration;
        one step is exact on tetrahedra and parallelepipeds)."""
        xc = self._local_nodes[self.cell_nodes[cells]]           # (n, nv, 3)
        X = np.tile(self._reference_centre(), (len(points), 1))
        for _ in range(_PULL_BACK_ITERATIONS):
            N, _, J = self._map(X, xc)
            residual = points - np.einsum("pi,pia->pa", N, xc)
            step = np.linalg.solve(J, residual[:, :, None])[:, :, 0]
            X += step
            if np.abs(step).max(initial=0.0) < _PULL_BACK_TOL:
                return X
        worst = np.argmax(np.abs(step).max(axis=1))
        raise RuntimeError(f"pull-back of point {points[worst].tolist()} into cell {cells[worst]} "
                           f"did not converge: the cell is too distorted")

    def _map(self, X, xc):
        """Shape function values N (n, nv), reference gradients dN (3, n, nv) and Jacobian
        J (n, 3, 3), J[p, a, d] = ∂x_a/∂X_d, at reference points X of cells with nodes xc."""
        if len(X) == 0:  # basix asserts on an empty point set
            nv = self.cell_nodes.shape[1]
            return np.empty((0, nv)), np.empty((3, 0, nv)), np.empty((0, 3, 3))
        tab = self.basis.tabulate(1, X)[:, :, :, 0]
        return tab[0], tab[1:], np.einsum("dpi,pia->pad", tab[1:], xc)

    def _basis_at(self, cells, X):
        """Values (n, nv) and physical gradients (n, nv, 3) of the cells' shape functions."""
        N, dN, J = self._map(X, self._local_nodes[self.cell_nodes[cells]])
        return N, np.einsum("dpi,pda->pia", dN, np.linalg.inv(J))

    def _reference_centre(self):
        return self.basis.points.mean(axis=0)

    def _reference_excess(self, X):
        """How far reference coordinates lie outside the reference cell (0 inside)."""
        if self.cell_nodes.shape[1] == 4:                        # tetrahedron: X ≥ 0, ΣX ≤ 1
            return np.maximum(np.maximum(-X, 0).max(axis=1), X.sum(axis=1) - 1)
        return np.maximum(np.maximum(-X, X - 1), 0).max(axis=1)

    # --- stress -----------------------------------------------------------------------------
    def stress(self):
        """Cell-average (DG0) Cauchy stress of the current u, with von Mises and largest
        principal stress per owned cell."""
        if self._stress_op is None:
            self._stress_op = self._cell_average_stress_operator()
        A, cell_rows = self._stress_op
        sigma_vec = A.createVecLeft()
        A.mult(self._u_vec, sigma_vec)
        sigma = sigma_vec.array[cell_rows].reshape(-1, 3, 3)
        dev = sigma - np.trace(sigma, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3
        von_mises = np.sqrt(1.5 * np.einsum("cab,cab->c", dev, dev))
        return CellStress(sigma, von_mises, np.linalg.eigvalsh(sigma)[:, -1])

    def _cell_average_stress_operator(self):
        """PETSc matrix u ↦ (1/|cell|) ∫_cell σ(u) over the DG0 tensor dofs, and the rows of
        its owned part in cell order (row 9 c + 3 a + b)."""
        T = fem.TensorFunctionSpace(self.msh, ("DG", 0))
        Q = fem.FunctionSpace(self.msh, ("DG", 0))
        A = petsc.assemble_matrix(fem.form(ufl.inner(self._sigma(ufl.TrialFunction(self.V)),
                                                     ufl.TestFunction(T)) * self.dx))
        A.assemble()
        volume = petsc.assemble_vector(fem.form(ufl.TestFunction(Q) * self.dx)).array
        n_cells = len(self.cell_nodes)
        rows = (9 * T.dofmap.list.array[:n_cells, None] + np.arange(9)).ravel()
        inverse_volume = A.createVecLeft()
        inverse_volume.array[rows] = np.repeat(1.0 / volume[Q.dofmap.list.array[:n_cells]], 9)
        A.diagonalScale(L=inverse_volume)
        return A, rows

    def _interpolated(self, weight):
        f = fem.Function(fem.FunctionSpace(self.msh, ("Lagrange", 1)))
        f.interpolate(lambda x: weight(x.T))
        f.x.scatter_forward()     # ghost nodes of cells another rank owns are set there only
        if not np.all(f.x.array > 0):
            raise ValueError(f"FE weight must be > 0 at every node, got min {f.x.array.min()!r}")
        return f

    def _sigma(self, w):
        e = _eps(w)
        return 2 * self.mu * e + self.lmbda * ufl.tr(e) * ufl.Identity(3)

    def _dirichlet_mask(self, dirichlet):
        msh = self.msh
        fdim = msh.topology.dim - 1
        msh.topology.create_connectivity(fdim, msh.topology.dim)
        fixed = np.zeros(3 * len(self._local_nodes), bool)
        for i, (locator, components) in enumerate(dirichlet):
            facets = locate_entities_boundary(msh, fdim, locator)
            if self.comm.allreduce(facets.size) == 0:
                raise ValueError(f"Dirichlet condition {i}: its locator matches no boundary facet")
            for c in components:
                if c not in (0, 1, 2):
                    raise ValueError(f"Dirichlet condition {i}: component {c!r} not in (0, 1, 2)")
                fixed[fem.locate_dofs_topological(self.V.sub(c), fdim, facets)] = True
        return fixed[:self.ndof]


def _check_located(found, points):
    outside = np.flatnonzero(~found)
    if outside.size:
        j = outside[0]
        raise ValueError(f"point {j} at {points[j].tolist()} is in no FE cell "
                         f"({outside.size} of {len(points)} points are outside the mesh)")


def _eps(w):
    return ufl.sym(ufl.grad(w))
