"""Surfaces in contact paired node by node (geometry.pairing): matching surfaces node for
node, non-matching ones node to surface with interpolation weights that carry linear fields
exactly, tributary areas that sum to the contact area, normals from body a into body b."""

import numpy as np
import pytest
from blocks import two_blocks

from microslip.geometry import Mesh
from microslip.geometry.mesh import rotation_z
from microslip.geometry.pairing import normal_frames, pair_surfaces


def _two_blocks(shape: str, lower_cells, upper_cells, shift=(0.0, 0.0)) -> Mesh:
    """A 0.06 x 0.03 x 0.01 m block standing on a 0.1 x 0.05 x 0.02 m one (its footprint
    inside the lower top face, moved by ``shift``), both in ``shape``."""
    return two_blocks((shape, lower_cells), (shape, upper_cells),
                      offset=(0.02 + shift[0], 0.01 + shift[1]))


@pytest.mark.parametrize("shape", ["hexahedron", "wedge", "tetra"])
def test_non_matching_surfaces_pair_node_to_surface(shape):
    """The upper block's bottom (finer) on the lower block's top: every weight row
    interpolates a linear field exactly, the areas sum to the footprint 0.06 x 0.03 m, the
    normals point down (from the upper body into the lower), gaps and outside distances 0."""
    mesh = _two_blocks(shape, (5, 4, 1), (7, 5, 1))
    p = pair_surfaces(mesh, "upper", mesh.node_sets["upper/bottom"], "lower",
                      mesh.node_sets["lower/top"])
    assert not p.matching
    np.testing.assert_allclose(p.weights.sum(axis=1), 1.0, atol=1e-12)
    field = lambda x: 3.0 * x[:, 0] - 2.0 * x[:, 1] + 0.5  # noqa: E731
    np.testing.assert_allclose(p.weights @ field(mesh.points[p.nodes_b]),
                               field(mesh.points[p.nodes_a]), atol=1e-12)
    assert p.area == pytest.approx(0.06 * 0.03, rel=1e-12)
    np.testing.assert_allclose(p.normals, np.tile([0.0, 0.0, -1.0], (len(p.nodes_a), 1)),
                               atol=1e-12)
    assert np.abs(p.gaps).max() < 1e-12 and p.outside.max() < 1e-12


def test_matching_surfaces_pair_node_for_node_and_the_ground():
    """Two blocks whose faces share the grid (the lower one's top cut to the footprint by a
    matching grid) pair node for node; against the ground, side a alone."""
    mesh = _two_blocks("hexahedron", (5, 5, 1), (3, 3, 1), shift=(-0.02, -0.01))
    top = mesh.node_sets["lower/top"]
    under = top[(mesh.points[top, 0] <= 0.06 + 1e-12) & (mesh.points[top, 1] <= 0.03 + 1e-12)]
    # the lower grid has spacing 0.02 x 0.01: its nodes under the 0.06 x 0.03 footprint match
    p = pair_surfaces(mesh, "upper", mesh.node_sets["upper/bottom"], "lower", under)
    assert p.matching
    np.testing.assert_array_equal(mesh.points[p.nodes_b[p.weights.indices]],
                                  mesh.points[p.nodes_a])
    ground = pair_surfaces(mesh, "upper", mesh.node_sets["upper/bottom"], None, None)
    assert ground.weights.shape == (len(ground.nodes_a), 0) and ground.area == pytest.approx(
        0.06 * 0.03, rel=1e-12)


def test_a_neighbouring_surface_is_turned_before_pairing():
    """Side b given in the fundamental sector and turned by the sector angle meets side a
    where it touches: the same pairing as the turned copy of the mesh."""
    mesh = _two_blocks("tetra", (5, 4, 1), (7, 5, 1))
    phi = 2 * np.pi / 24
    turn = rotation_z(phi)
    back = Mesh(mesh.model, np.where(np.isin(np.arange(len(mesh.points)),
                                             mesh.body_nodes("lower"))[:, None],
                                     mesh.points @ turn, mesh.points),
                mesh.tetrahedra, mesh.bodies, mesh.node_sets)
    direct = pair_surfaces(mesh, "upper", mesh.node_sets["upper/bottom"], "lower",
                           mesh.node_sets["lower/top"])
    turned = pair_surfaces(back, "upper", back.node_sets["upper/bottom"], "lower",
                           back.node_sets["lower/top"], rotation=turn)
    assert abs(direct.weights - turned.weights).max() < 1e-10


def test_stiffness_shared_by_area_and_frames_per_normal():
    """The flat punch of the paired area shared by tributary area: the pairs' stiffnesses
    sum to the patch's flat punch of 0.06 x 0.03 m; frames orthonormal, right-handed, n
    the pair's normal."""
    from microslip.fe import contact_stiffness as cs
    from microslip.fe.fem import Material

    steel = Material(2.0e11, 0.3, 7850.0)
    mesh = _two_blocks("tetra", (5, 4, 1), (7, 5, 1))
    p = pair_surfaces(mesh, "upper", mesh.node_sets["upper/bottom"], "lower",
                      mesh.node_sets["lower/top"])
    k = cs.pairing_stiffness("pad", p.areas, steel, steel)
    kn, kt = cs.flat_punch_stiffness(0.06 * 0.03, steel, steel)
    assert k.total_normal == pytest.approx(kn, rel=1e-12)
    assert k.total_tangential == pytest.approx(kt, rel=1e-12)
    np.testing.assert_allclose(k.normal / kn, p.areas / p.area, rtol=1e-12)
    F = normal_frames(p.normals)
    np.testing.assert_allclose(F @ np.transpose(F, (0, 2, 1)), np.tile(np.eye(3), (len(F), 1, 1)),
                               atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(F), 1.0, atol=1e-12)
    np.testing.assert_allclose(F[:, 2], p.normals, atol=1e-12)
    per_area = cs.pairing_stiffness("pad", p.areas, steel, steel, (1e13, 5e12))
    assert per_area.total_normal == pytest.approx(1e13 * 0.06 * 0.03, rel=1e-12)
