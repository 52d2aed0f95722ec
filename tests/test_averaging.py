"""Contact points apart from the mesh: averaged masters in the Craig-Bampton reduction
(against the unreduced model with the averages as constraints) and the cell averages of a
finer contact mesh (consistent loads, linear fields)."""

import dataclasses

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from microslip import geometry
from microslip.fe import craig_bampton, cyclic, eigen, fem, linalg, reduced_model
from microslip.geometry.averaging import cell_averages
from microslip.geometry.boundaries import MeshValidationError
from microslip.geometry.pairing import nodal_areas_and_normals
from microslip.geometry.surfaces import Surface, surface_of

STEEL = fem.Material(2.1e11, 0.3, 7800.0)
NS = 6


def _rim_cells(mesh, cells: int):
    """Two averaged points on the rim near theta = 0, each the tributary-area average of
    the rim's triangles in one axial half (the cells of a contact patch)."""
    rim = fem.node_set(mesh, "disk/rim")
    surface = surface_of(mesh.body_cells("disk"), rim)
    xyz = mesh.points[surface.triangles].mean(axis=1)
    theta = np.arctan2(xyz[:, 1], xyz[:, 0])
    near = np.abs(theta) < np.pi / NS / 3
    tri = surface.triangles[near]
    z = xyz[near, 2]
    cell = np.minimum(((z - z.min()) / np.ptp(z) * cells).astype(int), cells - 1)
    part = Surface(tri, np.empty((0, 4), np.int64))
    rows, nodes, weights, where = cell_averages(mesh.points, part, cell, cells)
    ids = len(mesh.points) + np.arange(cells)
    return dataclasses.replace(mesh, points=np.vstack([mesh.points, where]),
                               averages=np.column_stack([ids[rows], nodes]),
                               average_weights=weights), ids


def _constraints(mesh, model, ids):
    """(3p, n_free) W of the averaged points on the free coordinates (the definition)."""
    rows, nodes, w = mesh.averaging(ids)
    dofs = model.body.dofs_of_nodes(nodes)
    r = 3 * rows[:, None] + np.arange(3)
    W = sp.csr_matrix((np.repeat(w, 3), (r.ravel(), dofs.ravel())),
                      shape=(3 * len(ids), model.body.n_dofs))
    return (W @ model.expansion).tocsr()


@pytest.fixture(scope="module")
def coarse():
    mesh = geometry.annular_sector(sectors=NS, r_inner=0.05, r_outer=0.12, width=0.01,
                                   size=0.03)
    mesh, ids = _rim_cells(mesh, 2)
    body = fem.assemble(mesh, "disk", STEEL, order=1)
    return mesh, body, ids


@pytest.mark.parametrize("h", [0, 1])
def test_complete_basis_with_averaged_masters_is_exact(coarse, h):
    """Every constrained fixed-interface mode kept: the averaged masters' static modes and
    the modes with W u = 0 span the whole space, so the reduced model has the unreduced
    spectrum (ND 1: complex Hermitian, W through the cyclic expansion)."""
    mesh, body, ids = coarse
    model = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], h)
    node = np.setdiff1d(fem.node_set(mesh, "disk/rim"), mesh.cyclic["disk"].right)[:1]
    masters = np.concatenate([node, ids])
    n_slave = model.n_free - 3 * len(masters)
    red = craig_bampton.craig_bampton(model, masters, n_slave,
                                  averaged=craig_bampton.averaged_masters(mesh, masters))
    lam_full = sla.eigh(model.stiffness.toarray(), model.mass.toarray(), eigvals_only=True)
    lam_red = sla.eigh(red.stiffness, red.mass, eigvals_only=True)
    # A change of basis: round-off of dense LAPACK on a few hundred DOFs (1e-9 relative of
    # the largest; the lowest are compared on their own scale below).
    np.testing.assert_allclose(lam_red, lam_full, rtol=1e-9, atol=1e-9 * lam_full.max())
    np.testing.assert_allclose(lam_red[:10], lam_full[:10], rtol=1e-8)


@pytest.fixture(scope="module")
def fine():
    mesh = geometry.annular_sector(sectors=NS, r_inner=0.05, r_outer=0.12, width=0.01,
                                   size=0.012)
    mesh, ids = _rim_cells(mesh, 3)
    body = fem.assemble(mesh, "disk", STEEL)
    return mesh, body, ids


@pytest.mark.slow  # a long verification against the unreduced model (3.5 s)
def test_static_condensation_equals_the_constrained_unreduced_model(fine):
    """The reduced stiffness on averaged masters is the unreduced model's stiffness under
    the constraints W u = v, from one direct sparse solve of the saddle-point system
    [[K, W^H], [W, 0]] [U; L] = [0; I] (k = -L: the forces that hold W u = v). The
    augmented-Lagrangian path of the reduction is independent of it."""
    mesh, body, ids = fine
    model = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], 1)
    red = craig_bampton.craig_bampton(model, ids, "auto",
                                  averaged=craig_bampton.averaged_masters(mesh, ids))
    W = _constraints(mesh, model, ids)
    c = W.shape[0]
    A = sp.bmat([[model.stiffness, W.conj().T], [W, None]]).tocsc()
    rhs = np.vstack([np.zeros((model.n_free, c)), np.eye(c)]).astype(complex)
    k = -spla.spsolve(A, rhs)[model.n_free:]
    # Exact in exact arithmetic (CB's static modes are the constrained static solution);
    # 1e-8 of the largest entry covers the factorizations' round-off at cond(K) ~ 1e8.
    np.testing.assert_allclose(red.stiffness[:c, :c], k, atol=1e-8 * np.abs(k).max())
    np.testing.assert_allclose(red.master_coordinates, mesh.points[ids], atol=1e-15)


@pytest.mark.slow  # (a convergence study: 3.7 s of the fast suite)
def test_free_vibration_frequencies_converge_to_the_unreduced_model(fine):
    """The masters free, the reduced model's lowest frequencies are the unreduced model's
    within the Craig-Bampton error of the default cut-off (< 0.1 % on the first ten, see
    reduced_model.CUTOFF); the constrained modes come from the block Krylov solver here (a
    few thousand DOFs)."""
    mesh, body, ids = fine
    model = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], 2)
    red = craig_bampton.craig_bampton(model, ids, "auto",
                                  averaged=craig_bampton.averaged_masters(mesh, ids))
    assert model.n_free > 2000  # (the Krylov path, not the dense one)
    lam, _ = eigen.lowest_modes(model.stiffness, model.mass, 10)
    f_full = np.sqrt(lam) / (2 * np.pi)
    np.testing.assert_allclose(red.frequencies(10), f_full, rtol=1e-3)


def test_an_averaged_point_of_one_node_is_that_node_as_master(coarse):
    """A point averaging one node with weight 1 is that node: the same reduced model as
    the node made a master (the constrained path against the partitioned one)."""
    mesh, body, _ = coarse
    node = np.setdiff1d(fem.node_set(mesh, "disk/rim"), mesh.cyclic["disk"].right)[:2]
    point = len(mesh.points) + np.arange(2)
    tied = dataclasses.replace(mesh, points=np.vstack([mesh.points, mesh.points[node]]),
                               averages=np.column_stack([point, node]),
                               average_weights=np.ones(2))
    body_t = fem.assemble(tied, "disk", STEEL, order=1)
    bore = fem.node_set(mesh, "disk/bore")
    plain = craig_bampton.craig_bampton(cyclic.sector_model(body, bore, mesh.cyclic["disk"], 1),
                                    node, 12)
    avg = craig_bampton.craig_bampton(cyclic.sector_model(body_t, bore, tied.cyclic["disk"], 1),
                                  point, 12, averaged=craig_bampton.averaged_masters(tied, point))
    np.testing.assert_allclose(avg.frequencies(), plain.frequencies(), rtol=1e-9)
    # The master block (static condensation) alike: round-off of two factorizations.
    np.testing.assert_allclose(avg.stiffness[:6, :6], plain.stiffness[:6, :6],
                               atol=1e-9 * np.abs(plain.stiffness[:6, :6]).max())


def test_blisk_cells_carry_a_uniform_pressure_as_its_consistent_loads():
    """The fine-flank blisk: the averaged points' weights times their equal areas give
    every flank node its consistent nodal area (int N_k dA: a uniform pressure arrives as
    on the fine mesh), and each point sits at its cell's centre; the free-free damper held
    only by averaged masters keeps exactly six rigid-body modes."""
    mesh = geometry.blisk_sector(contact_size=0.002)
    for name, patch in mesh.contacts.items():
        n1, n2 = patch.shape
        rows, nodes, w = mesh.averaging(patch.nodes_a.ravel())
        load = np.zeros(len(mesh.points))
        np.add.at(load, nodes, w * patch.area / (n1 * n2))
        face = surface_of(mesh.body_cells("damper"), np.unique(nodes))
        k, area, _ = nodal_areas_and_normals(mesh.points, face)
        # Sums of the same triangle areas in another order: round-off.
        np.testing.assert_allclose(load[k], area, rtol=1e-9, err_msg=name)
        grid = mesh.points[patch.nodes_a]
        step = np.linalg.norm(grid[1, 0] - grid[0, 0])
        np.testing.assert_allclose(np.linalg.norm(grid[0, 0] - grid[1, 1]),
                                   np.hypot(step, np.linalg.norm(grid[0, 1] - grid[0, 0])))
    damper = fem.assemble(mesh, "damper", STEEL)
    ids = mesh.averaged_points[np.isin(mesh.averaged_points,
                                       mesh.body_points("damper"))]
    model = cyclic.sector_model(damper, np.empty(0, np.int64), None, 0)
    red = craig_bampton.craig_bampton(model, ids, 4,
                                      averaged=craig_bampton.averaged_masters(mesh, ids))
    f = red.frequencies()
    assert np.sum(f < reduced_model.RIGID * f[-1]) == 6


def test_a_point_off_its_average_is_refused(coarse):
    mesh, _, ids = coarse
    moved = mesh.points.copy()
    moved[ids[0]] += 1e-6
    with pytest.raises(MeshValidationError, match="off the weighted mean"):
        dataclasses.replace(mesh, points=moved)


def test_constrained_factor_solves_the_saddle_point_system():
    """x of K x + W^H l = b, W x = g, K singular (a free body) and held only by W, against
    a dense solve of the saddle-point matrix."""
    rng = np.random.default_rng(3)
    n, c = 40, 6
    B = rng.standard_normal((n, n - 3))
    K = sp.csr_matrix(B @ B.T)  # rank n - 3
    W = sp.csr_matrix(rng.standard_normal((c, n)) * (rng.random((c, n)) < 0.3))
    b, g = rng.standard_normal((n, 2)), rng.standard_normal((c, 2))
    F = linalg.ConstrainedFactor(K, W)
    x = F.solve(b, g)
    A = np.block([[K.toarray(), W.T.toarray()], [W.toarray(), np.zeros((c, c))]])
    want = np.linalg.solve(A, np.vstack([b, g]))[:n]
    # cond(A) ~ 1e4 here: 1e-9 relative is round-off.
    np.testing.assert_allclose(x, want, atol=1e-9 * np.abs(want).max())


def test_averages_among_the_masters_only_and_the_modes_they_leave(coarse):
    """Averaged points that are not masters are left out (not read as garbage rows); the
    mode count is bounded by the slave space less the averages held (one line, not a
    broadcast error deep in the eigen-solve)."""
    mesh, body, ids = coarse
    model = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], 1)
    every = craig_bampton.averaged_masters(mesh, ids)
    one = craig_bampton.craig_bampton(model, ids[:1], 5, averaged=every)
    alone = craig_bampton.craig_bampton(model, ids[:1], 5,
                                    averaged=craig_bampton.averaged_masters(mesh, ids[:1]))
    np.testing.assert_allclose(one.stiffness, alone.stiffness, rtol=1e-12, atol=1e-9)
    n_slave = model.n_free - 3 * len(ids)
    with pytest.raises(ValueError, match="n_modes"):
        craig_bampton.craig_bampton(model, ids, n_slave + 1, averaged=every)
