"""Cyclic symmetry: the sector over ND 0..Ns/2 is exactly the full disk built from copies."""

import numpy as np
import pytest

from microslip import geometry
from microslip.fe import cyclic, eigen, fem
from microslip.geometry.mesh import rotation_z

STEEL = fem.Material(2.1e11, 0.3, 7800.0)
NS = 4  # ND 0 and 2 real, ND 1 complex with mode pairs


@pytest.fixture(scope="module")
def sector():
    mesh = geometry.annular_sector(sectors=NS, r_inner=0.05, r_outer=0.1, width=0.01, size=0.02)
    body = fem.assemble(mesh, "disk", STEEL)
    return mesh, body


@pytest.fixture(scope="module")
def full_disk(sector):
    mesh, _ = sector
    node_map = geometry.disk_node_map(mesh)
    body = fem.assemble(geometry.full_disk(mesh), "disk", STEEL)
    bore = np.unique(node_map[:, fem.node_set(mesh, "disk/bore")])
    model = cyclic.sector_model(body, bore)
    return model, node_map


def test_harmonic_to_nodal_diameter():
    # Ns = 24, EO = 5: n = 1 -> 5 (forward); n = 3 -> 15 > 12 -> ND 9 backward (conjugate);
    # n = 0 -> ND 0; n = 5 -> 25 mod 24 = 1.
    assert cyclic.harmonic_nodal_diameter(1, 5, 24) == (5, False)
    assert cyclic.harmonic_nodal_diameter(3, 5, 24) == (9, True)
    assert cyclic.harmonic_nodal_diameter(0, 5, 24) == (0, False)
    assert cyclic.harmonic_nodal_diameter(5, 5, 24) == (1, False)
    # Ns = 12, EO = 3, n = 2: ND 6 = Ns/2, a standing wave, real matrices, not conjugated.
    assert cyclic.harmonic_nodal_diameter(2, 3, 12) == (6, False)
    assert cyclic.nodal_diameters(range(4), 5, 24) == (0, 5, 9, 10)


def test_sector_matrices_hermitian_real_at_0_and_half(sector):
    mesh, body = sector
    bore = fem.node_set(mesh, "disk/bore")
    for h in range(NS // 2 + 1):
        m = cyclic.sector_model(body, bore, mesh.cyclic["disk"], h)
        assert m.is_complex == (0 < h < NS / 2)
        for A in (m.stiffness, m.mass):
            assert abs(A - A.conj().T).max() == 0.0  # Hermitian by construction


def test_sector_reproduces_full_disk(sector, full_disk):
    mesh, body = sector
    full, _ = full_disk
    bore = fem.node_set(mesh, "disk/bore")
    n_low = 24
    lam_sector = []
    for h in range(NS // 2 + 1):
        m = cyclic.sector_model(body, bore, mesh.cyclic["disk"], h)
        lam, _ = eigen.lowest_modes(m.stiffness, m.mass, 12)
        pair = 2 if 0 < h < NS / 2 else 1  # travelling-wave pairs appear twice in the disk
        lam_sector.extend(np.repeat(lam, pair))
    lam_sector = np.sort(lam_sector)[:n_low]
    lam_full, _ = eigen.lowest_modes(full.stiffness, full.mass, n_low)
    # Same element matrices up to rotation round-off: agreement is ~1e-13 (measured);
    # 1e-8 leaves the eigensolver's convergence tolerance (1e-10 on the residual) room.
    np.testing.assert_allclose(lam_full, lam_sector, rtol=1e-8)
    assert np.sum(np.isclose(lam_full[:-1], lam_full[1:], rtol=1e-8)) >= 4  # pairs present


def test_expanded_sector_mode_is_a_full_disk_mode(sector, full_disk):
    mesh, body = sector
    full, node_map = full_disk
    h = 1
    m = cyclic.sector_model(body, fem.node_set(mesh, "disk/bore"), mesh.cyclic["disk"], h)
    lam, V = eigen.lowest_modes(m.stiffness, m.mass, 1)
    u_body = m.expansion @ V[:, 0]
    u_nodes = u_body[body.node_dofs]  # (n_v, 3) in body.nodes order
    u_disk = cyclic.expand_to_disk(u_nodes, h, NS)  # (Ns, n_v, 3)
    # Scatter the copies on the full-disk vertices (right-face nodes coincide with the next
    # copy's left face and must carry the same value: a consistency check of the expansion).
    full_body = full.body
    u_full = np.zeros((len(full_body.nodes), 3), dtype=complex)
    for s in range(NS):
        u_full[full_body.local_nodes(node_map[s, body.nodes])] = u_disk[s]
    right = mesh.cyclic["disk"].right
    left = mesh.cyclic["disk"].left
    pos = body.local_nodes
    np.testing.assert_allclose(u_disk[0][pos(right)], u_disk[1][pos(left)], atol=1e-12)
    # The full-disk residual at the vertex DOFs, with P2 edge DOFs solved from the vertex
    # values through the same expansion: build the full vector from the sector copies.
    x = np.zeros(full_body.n_dofs, dtype=complex)
    x[full_body.node_dofs] = u_full
    for s in range(NS):
        R = np.exp(1j * h * s * 2 * np.pi / NS) * rotation_z(s * 2 * np.pi / NS)
        e_full = full_body.edge_index(node_map[s][body.edges])
        assert np.all(e_full >= 0)
        x[full_body.edge_dofs[e_full]] = u_body[body.edge_dofs] @ R.T
    x = x[full.free_dofs]
    K, M = full.stiffness, full.mass
    residual = np.linalg.norm(K @ x - lam[0] * (M @ x)) / np.linalg.norm(K @ x)
    assert residual < 1e-8  # an exact eigenvector up to round-off


@pytest.mark.parametrize("h", [-1, NS // 2 + 1, 1.5])
def test_bad_nodal_diameter(sector, h):
    mesh, body = sector
    with pytest.raises(ValueError, match="nodal_diameter"):
        cyclic.sector_model(body, (), mesh.cyclic["disk"], h)


def test_right_face_master_is_refused(sector):
    mesh, body = sector
    m = cyclic.sector_model(body, (), mesh.cyclic["disk"], 1)
    with pytest.raises(ValueError, match="right cyclic face"):
        m.free_index(mesh.cyclic["disk"].right[:2])
