"""Assembly: DOF maps, rigid-body and mass checks, Euler-Bernoulli cantilever, bad input."""

import numpy as np
import pytest
import skfem as fe

from microslip import geometry
from microslip.fe import cyclic, eigen, fem

STEEL = fem.Material(2.1e11, 0.3, 7800.0)
L, W, H = 1.0, 0.03, 0.02  # slender: L/H = 50, L/W = 33


@pytest.fixture(scope="module")
def beam_mesh():
    return geometry.beam(L, W, H, 0.04)


def _doflocs(mesh, body, order):
    """DOF locations straight from scikit-fem (independent of BodyModel's tables)."""
    tets = mesh.body_cells(body)["tetra"]
    nodes, local = np.unique(tets, return_inverse=True)
    skm = fe.MeshTet(np.asarray(mesh.points)[nodes].T, local.reshape(tets.shape).T)
    elem = fe.ElementVector(fe.ElementTetP2() if order == 2 else fe.ElementTetP1())
    return fe.Basis(skm, elem, intorder=2).doflocs.T  # (N, 3)


@pytest.mark.parametrize("order", [1, 2])
def test_node_dof_map_matches_dof_locations(beam_mesh, order):
    body = fem.assemble(beam_mesh, "beam", STEEL, order)
    locs = _doflocs(beam_mesh, "beam", order)
    tip = fem.node_set(beam_mesh, "beam/tip_centre")
    dofs = body.dofs_of_nodes(tip)
    assert dofs.shape == (1, 3)
    # Each of the three DOFs of the node sits at the node, exactly (same float data).
    np.testing.assert_array_equal(locs[dofs[0]], np.repeat(beam_mesh.points[tip], 3, axis=0))
    # The clamp-face DOFs are exactly the DOFs located on x = 0 (vertex and P2 edge DOFs).
    clamp = body.set_dofs(fem.node_set(beam_mesh, "beam/clamp"))
    on_face = np.flatnonzero(np.abs(locs[:, 0]) < 1e-12)
    np.testing.assert_array_equal(clamp, on_face)
    # x, y, z ordering of the triple: component k of DOF node_dofs[:, k].
    np.testing.assert_array_equal(np.diff(body.node_dofs, axis=1), 1)


@pytest.mark.parametrize("order", [1, 2])
def test_rigid_body_motion_and_total_mass(beam_mesh, order):
    body = fem.assemble(beam_mesh, "beam", STEEL, order)
    locs = _doflocs(beam_mesh, "beam", order)
    comp = np.zeros(body.n_dofs, dtype=int)
    comp[body.node_dofs.ravel()] = np.tile([0, 1, 2], len(body.nodes))
    if len(body.edge_dofs):
        comp[body.edge_dofs.ravel()] = np.tile([0, 1, 2], len(body.edge_dofs))
    K, M = body.stiffness, body.mass
    scale = abs(K).max()
    for k in range(3):
        u = (comp == k).astype(float)  # unit translation
        # Translation: no strain energy (round-off level relative to K's entries).
        assert np.abs(K @ u).max() < 1e-9 * scale
        # Mass is exact for a translation: rho * volume of the (straight-sided) mesh.
        assert u @ M @ u == pytest.approx(STEEL.density * beam_mesh.body_volume("beam"), 1e-12)
    # Rotation about z: u = (-y, x, 0) is linear, so exactly representable: zero energy.
    u = np.where(comp == 0, -locs[:, 1], 0.0) + np.where(comp == 1, locs[:, 0], 0.0)
    assert np.abs(K @ u).max() < 1e-9 * scale


def euler_bernoulli(mode: int, inertia: float) -> float:
    """Cantilever bending frequency [Hz], beta_n L from the clamped-free characteristic eq."""
    beta_l = (1.8751040687, 4.6940911330)[mode]
    return beta_l**2 / (2 * np.pi * L**2) * np.sqrt(
        STEEL.youngs_modulus * inertia / (STEEL.density * W * H)
    )


REFERENCE = {
    "z1": euler_bernoulli(0, W * H**3 / 12),
    "y1": euler_bernoulli(0, H * W**3 / 12),
    "z2": euler_bernoulli(1, W * H**3 / 12),
    "y2": euler_bernoulli(1, H * W**3 / 12),
}


def bending_frequencies(size: float) -> dict[str, float]:
    """First two bending frequencies [Hz] in y and z of the clamped P2 beam."""
    mesh = geometry.beam(L, W, H, size)
    body = fem.assemble(mesh, "beam", STEEL)
    model = cyclic.sector_model(body, fem.node_set(mesh, "beam/clamp"))
    lam, V = eigen.lowest_modes(model.stiffness, model.mass, 8)
    tip = body.dofs_of_nodes(fem.node_set(mesh, "beam/tip_centre")).ravel()
    u_tip = np.abs((model.expansion @ V)[tip])  # (3, 8)
    found: dict[str, float] = {}
    for j in range(8):
        d = int(np.argmax(u_tip[:, j]))
        if u_tip[d, j] < 1e-3 * np.abs(V[:, j]).max():
            continue  # torsion: the tip centre does not move
        label = "xyz"[d] + str(1 + sum(k[0] == "xyz"[d] for k in found))
        found[label] = float(np.sqrt(lam[j]) / (2 * np.pi))
    return {k: found[k] for k in REFERENCE}


def _check_convergence(sizes):
    results = [bending_frequencies(s) for s in sizes]
    for res in results:
        for key, f in res.items():
            # 0.5 %: what the 3D effects Euler-Bernoulli leaves out allow
            # (shear and rotary inertia ~0.15 % for mode 2 at L/W = 33, Poisson at the clamp).
            assert f == pytest.approx(REFERENCE[key], rel=5e-3), (key, f, REFERENCE[key])
    for key in REFERENCE:
        steps = np.abs(np.diff([r[key] for r in results]))
        assert np.all(np.diff(steps) < 0), (key, steps)  # the mesh sequence converges


def test_beam_converges_to_euler_bernoulli():
    _check_convergence([0.04, 0.02])


@pytest.mark.slow
def test_beam_converges_to_euler_bernoulli_fine():
    _check_convergence([0.04, 0.02, 0.01])


def test_damping_options():
    K = np.diag([1.0, 4.0, 9.0]) * 1e4
    M = np.eye(3)
    C = fem.damping_matrix(K, M, fem.Damping(rayleigh_alpha=2.0, rayleigh_beta=1e-4))
    np.testing.assert_allclose(C, 2.0 * M + 1e-4 * K)
    # Modal: diag(2 zeta omega) for a diagonal system; the last ratio extends to higher modes.
    C = fem.damping_matrix(K, M, fem.Damping(modal_ratios=(0.01, 0.02)))
    np.testing.assert_allclose(np.diag(C), 2 * np.array([0.01, 0.02, 0.02]) * [100, 200, 300])
    assert fem.damping_matrix(K, M, fem.Damping()) is None


def test_modal_ratios_go_to_the_elastic_modes_of_a_free_chain():
    # Three equal masses m joined by two springs k, free at both ends: omega^2 = (0, 1, 3) k/m
    # by hand. The rigid mode takes no damping and the ratios go to the elastic modes in order.
    k, m = 4.0e4, 2.0
    K = k * np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    M = m * np.eye(3)
    C = fem.modal_damping(K, M, [0.01, 0.02])
    np.testing.assert_allclose(C @ np.ones(3), 0.0, atol=1e-12 * np.abs(C).max())
    w = np.sqrt(np.array([1.0, 3.0]) * k / m)
    phi = np.array([[1.0, 0.0, -1.0], [1.0, -2.0, 1.0]]).T  # the elastic modes by hand
    phi /= np.sqrt(np.einsum("ij,ij->j", phi, M @ phi))
    np.testing.assert_allclose(phi.T @ C @ phi, np.diag(2.0 * np.array([0.01, 0.02]) * w),
                               rtol=1e-12, atol=1e-12 * 2 * 0.02 * w[1])


def _spring_network(points: np.ndarray, k: float) -> np.ndarray:
    """Stiffness (3n, 3n) of axial springs k between every pair of ``points`` (n, 3)."""
    n = len(points)
    K = np.zeros((3 * n, 3 * n))
    for a in range(n):
        for b in range(a + 1, n):
            e = points[b] - points[a]
            e = np.outer(e, e) / (e @ e) * k
            for i, j, sign in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
                K[3 * i:3 * i + 3, 3 * j:3 * j + 3] += sign * e
    return K


def test_modal_damping_of_a_free_body_turns_with_it():
    # A free 3D body (springs between 5 points: 6 rigid modes with rounding eigenvalues) and
    # its copy turned by 0.7 rad: the damping must be the turned one, C' = R C R^T. With the
    # rigid modes damped in whatever basis eigh returned, the two differed by 1.1e-8 of the
    # largest entry (8e-16 now); 1e-12 leaves the elastic modes' own rounding room.
    rng = np.random.default_rng(3)
    points = rng.normal(size=(5, 3))
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    Rb = np.kron(np.eye(5), R)
    M = np.diag(np.repeat(rng.uniform(1.0, 2.0, 5), 3))
    K = _spring_network(points, 1.0e12)
    C = fem.modal_damping(K, M, [0.005])
    C_turned = fem.modal_damping(_spring_network(points @ R.T, 1.0e12), M, [0.005])
    assert np.abs(C_turned - Rb @ C @ Rb.T).max() < 1e-12 * np.abs(C).max()
    # and the rigid motions are undamped: a translation and an infinitesimal rotation
    rotation = np.cross(np.array([0.0, 0.0, 1.0]), points).ravel()
    for rigid in (np.tile([1.0, 0.0, 0.0], 5), rotation):
        assert np.abs(C @ rigid).max() < 1e-12 * np.abs(C).max() * np.abs(rigid).max()


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"poisson_ratio": 0.5}, "poisson_ratio"),
        ({"poisson_ratio": 0.7}, "poisson_ratio"),
        ({"youngs_modulus": -1.0}, "youngs_modulus"),
        ({"density": 0.0}, "density"),
    ],
)
def test_bad_material(kwargs, word):
    args = {"youngs_modulus": 2e11, "poisson_ratio": 0.3, "density": 7800.0, **kwargs}
    with pytest.raises(ValueError, match=word):
        fem.Material(**args)


def test_bad_names(beam_mesh):
    with pytest.raises(ValueError, match="node set 'beam/nothing' does not exist"):
        fem.node_set(beam_mesh, "beam/nothing")
    with pytest.raises(ValueError, match="body='blade' does not exist"):
        fem.assemble(beam_mesh, "blade", STEEL)
    with pytest.raises(ValueError, match="order=3"):
        fem.assemble(beam_mesh, "beam", STEEL, order=3)
    body = fem.assemble(beam_mesh, "beam", STEEL, order=1)
    with pytest.raises(ValueError, match="not vertices of body"):
        body.dofs_of_nodes([len(beam_mesh.points) + 5])
