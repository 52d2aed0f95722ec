"""The solid elements of every shape: the 15-node wedge and the wedge quadrature written here,
the patch test (constant strain exactly) on distorted and mixed meshes, mass, rigid motion,
and the cantilever's frequencies agreeing across shapes."""

from math import factorial

import numpy as np
import pytest
import scipy.linalg as sla

from microslip.fe import fem
from microslip.fe.basis import ElementWedgeS2, wedge_quadrature
from microslip.geometry import elements as shapes
from microslip.geometry.structured import block

STEEL = fem.Material(2.0e11, 0.3, 7850.0)
KINDS = ["tetra", "hexahedron", "wedge", "mixed"]


def _block(kind, **kw):
    return block("hexahedron", mixed=True, **kw) if kind == "mixed" else block(kind, **kw)


def test_wedge15_shape_functions():
    e = ElementWedgeS2()
    X = e.doflocs.T
    values = np.array([e.lbasis(X, i)[0] for i in range(15)])
    np.testing.assert_allclose(values, np.eye(15), atol=1e-14)  # nodal: Kronecker delta
    P = np.random.default_rng(1).random((3, 40))
    P[:2] *= 0.5  # inside the reference triangle
    phi = np.array([e.lbasis(P, i)[0] for i in range(15)])
    grad = np.array([e.lbasis(P, i)[1] for i in range(15)])
    np.testing.assert_allclose(phi.sum(axis=0), 1.0, atol=1e-14)  # partition of unity
    np.testing.assert_allclose(grad.sum(axis=0), 0.0, atol=1e-13)
    # complete to degree 2: x^2, x y, z^2, x z interpolated exactly from the nodal values
    for f in (lambda x, y, z: x * x, lambda x, y, z: x * y, lambda x, y, z: z * z,
              lambda x, y, z: x * z + y):
        np.testing.assert_allclose(f(*X) @ phi, f(*P), atol=1e-13)
    # gradients against central differences (step 1e-6: truncation 1e-12, round-off 1e-10)
    h = 1e-6
    for d in range(3):
        step = np.zeros((3, 1))
        step[d] = h
        fd = np.array([(e.lbasis(P + step, i)[0] - e.lbasis(P - step, i)[0]) / (2 * h)
                       for i in range(15)])
        np.testing.assert_allclose(grad[:, d], fd, atol=1e-8)


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_wedge_quadrature_is_exact(degree):
    X, W = wedge_quadrature(degree)
    assert (X[0] >= 0).all() and (X[1] >= 0).all() and (X[0] + X[1] <= 1 + 1e-14).all()
    for a in range(degree + 1):
        for b in range(degree + 1 - a):
            for c in range(degree + 1):  # int x^a y^b dA dz = a! b! / (a + b + 2)! / (c + 1)
                exact = factorial(a) * factorial(b) / factorial(a + b + 2) / (c + 1)
                # 1e-14: the triangle rule's tabulated points and weights carry ~1e-15
                assert (W * X[0] ** a * X[1] ** b * X[2] ** c).sum() == pytest.approx(
                    exact, abs=1e-14)


def _nodal_field(body, A, b):
    """u = A x + b at every DOF (vertices, and the quadratic elements' edge midpoints)."""
    u = np.zeros(body.n_dofs)
    u[body.node_dofs] = body.points @ A.T + b
    if len(body.edge_dofs):
        mid = body.points[body.local_nodes(body.edges.ravel()).reshape(-1, 2)].mean(axis=1)
        u[body.edge_dofs] = mid @ A.T + b
    return u


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("kind", KINDS)
def test_patch_test_mass_and_rigid_motion(kind, order):
    """Constant strain on a distorted mesh: the energy is that of the continuum exactly,
    interior nodes are in equilibrium; rigid motion costs no energy; the mass is rho V."""
    mesh = _block(kind, cells=(4, 3, 3), distort=0.25)
    body = fem.assemble(mesh, "block", STEEL, order)
    volume = 1.0 * 0.1 * 0.1  # distortion moves interior nodes only
    assert mesh.body_volume("block") == pytest.approx(volume, rel=1e-13)
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.0, 0.7]]) * 1e-3
    u = _nodal_field(body, A, np.array([1e-4, -2e-4, 3e-4]))
    eps = 0.5 * (A + A.T)
    energy = volume * (0.5 * STEEL.lame_lambda * np.trace(eps) ** 2
                       + STEEL.shear_modulus * np.sum(eps * eps))
    # exact quadrature of a constant integrand: round-off only (1e-12 relative)
    assert 0.5 * u @ (body.stiffness @ u) == pytest.approx(energy, rel=1e-11)
    boundary = np.unique(body.boundary_facets)
    interior = np.setdiff1d(body.nodes, boundary)
    f = body.stiffness @ u
    assert np.abs(f[body.dofs_of_nodes(interior)]).max() < 1e-9 * np.abs(f).max()
    for rigid in (np.zeros((3, 3)), np.array([[0, -1, 0], [1, 0, 0], [0, 0, 0]]) * 1e-3):
        r = _nodal_field(body, rigid, np.array([1e-3, 2e-3, -1e-3]))
        assert np.abs(body.stiffness @ r).max() < 1e-10 * np.abs(f).max()
    ex = _nodal_field(body, np.zeros((3, 3)), np.array([1.0, 0.0, 0.0]))
    assert ex @ (body.mass @ ex) == pytest.approx(STEEL.density * volume, rel=1e-12)


def _frequencies(mesh, order, n=4):
    body = fem.assemble(mesh, "block", STEEL, order)
    free = np.setdiff1d(np.arange(body.n_dofs), body.set_dofs(mesh.node_sets["block/clamp"]))
    K = body.stiffness[free][:, free].toarray()
    M = body.mass[free][:, free].toarray()
    return np.sqrt(sla.eigh(K, M, eigvals_only=True, subset_by_index=[0, n - 1])) / (2 * np.pi)


def test_cantilever_frequencies_agree_across_shapes():
    """A 1 x 0.1 x 0.1 m cantilever on the same 10 x 2 x 2 grid: the quadratic shapes give the
    first four frequencies (two bendings, torsion, ...) within their discretization error of
    each other, and of Euler-Bernoulli for the first bending."""
    f = {kind: _frequencies(_block(kind), 2) for kind in KINDS}
    # Euler-Bernoulli: f1 = 1.875^2 / (2 pi) sqrt(E I / (rho A L^4)); shear and 3D effects
    # at L/H = 10 lower it by ~1 %, so 2 % (the coarse mesh stiffens, by less)
    eb = 1.87510407**2 / (2 * np.pi) * np.sqrt(STEEL.youngs_modulus * 0.1**4 / 12
                                                / (STEEL.density * 0.01))
    for kind in KINDS:
        assert f[kind][0] == pytest.approx(eb, rel=2e-2), kind
    # hex20 and wedge15 share the grid's quadratic edges: within 1 %; tet10 (24 x the
    # elements, stiffer in bending on this grid) within 2 %
    for kind in ("wedge", "mixed"):
        np.testing.assert_allclose(f[kind], f["hexahedron"], rtol=1e-2)
    np.testing.assert_allclose(f["tetra"], f["hexahedron"], rtol=2e-2)


def test_inverted_and_tangled_elements_are_refused():
    mesh = block("wedge", cells=(2, 1, 1))
    flipped = mesh.wedges.copy()
    flipped[0] = flipped[0][[0, 2, 1, 3, 5, 4]]
    with pytest.raises(ValueError, match="wedges: 1 elements inverted"):
        type(mesh)("w", mesh.points, mesh.tetrahedra, mesh.bodies, wedges=flipped)
    assert shapes.inverted(mesh.points, "wedge", flipped).tolist() == [0]
