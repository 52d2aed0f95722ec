"""Two surfaces in contact, paired node by node: what a contact between any two named
surfaces needs from the mesh (Firrone & Zucca 5.2's node-to-node contact, generalized to
surfaces meshed independently).

Side a is the finer surface (more nodes); each of its nodes is a contact point:

* matching surfaces (every a-node has a coincident b-node): the pairs, node for node;
* otherwise node to surface: the a-node is projected onto side b; its partner displacement
  is side b's interpolated there with the facet's linear shape functions over its corner
  nodes (``weights``), and the pair's normal gap is measured to the projected point.

Each pair carries side a's tributary area (the consistent nodal area, int N_i dA over the
facets around the node: a third of each triangle, a bilinear quad's share) and side a's
unit normal there (the area-weighted mean of its facets' outward normals), pointing from
body a into body b. Side b may be a neighbouring sector's surface: its nodes are then
turned by ``rotation`` before the pairing (the cyclic phase is the assembly's business).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .mesh import Mesh
from .surfaces import Surface, interpolation, project, quad_map, quad_shapes, surface_of


@dataclass(frozen=True)
class SurfacePairing:
    """Side a's nodes and where they meet side b.

    nodes_a: (k,) side a's nodes (the contact points); nodes_b: (m,) side b's nodes the
    weights refer to; weights: (k, m) CSR, u_b'(i) = sum_j w_ij u_b(j) (each row sums to 1;
    identity rows for matching pairs); normals: (k, 3) unit normals of side a, from body a
    into body b; areas: (k,) tributary areas [m^2]; gaps: (k,) [m] normal distance from each
    a-node to its partner point on side b (positive: open); outside: (k,) [m] how far the
    projection fell outside side b (0: on it); matching: node-for-node pairs.
    """

    nodes_a: np.ndarray
    nodes_b: np.ndarray
    weights: sp.csr_matrix
    normals: np.ndarray
    areas: np.ndarray
    gaps: np.ndarray
    outside: np.ndarray
    matching: bool

    @property
    def area(self) -> float:
        """Side a's contact area [m^2]."""
        return float(self.areas.sum())


def nodal_areas_and_normals(points: np.ndarray, surface: Surface
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nodes (n,), tributary areas (n,) [m^2], unit normals (n, 3)) of a surface's nodes:
    int N_i dA with the facets' linear shape functions (2 x 2 Gauss on quads, exact for
    their bilinear map), normals the area-weighted mean of the facets' outward normals."""
    nodes = surface.nodes
    area = np.zeros(len(nodes))
    normal = np.zeros((len(nodes), 3))
    tri = np.searchsorted(nodes, surface.triangles)
    if len(tri):
        p = points[surface.triangles]
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # 2 A n
        a = 0.5 * np.linalg.norm(cross, axis=1)
        for c in range(3):
            np.add.at(area, tri[:, c], a / 3.0)
            np.add.at(normal, tri[:, c], 0.5 * cross)
    quads = np.searchsorted(nodes, surface.quads)
    if len(quads):
        p = points[surface.quads]
        g = 1.0 / np.sqrt(3.0)
        for xi in ([-g, -g], [g, -g], [g, g], [-g, g]):
            local = np.tile(xi, (len(p), 1))
            _, J = quad_map(p, local)
            cross = np.cross(J[:, :, 0], J[:, :, 1])  # dA = |x_xi x x_eta| dxi deta
            weight, _ = quad_shapes(local, 1)
            for c in range(4):
                np.add.at(area, quads[:, c], weight[:, c] * np.linalg.norm(cross, axis=1))
                np.add.at(normal, quads[:, c], weight[:, c, None] * cross)
    return nodes, area, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def pair_surfaces(mesh: Mesh, body_a: str, set_a: np.ndarray, body_b: str | None,
                  set_b: np.ndarray | None, rotation: np.ndarray | None = None,
                  tol: float = 1e-9) -> SurfacePairing:
    """Pair the surface of ``body_a`` in node set ``set_a`` with that of ``body_b`` in
    ``set_b`` (``body_b`` None: the ground; side b is then rigid and the gaps zero).

    The caller picks side a as the finer side. ``rotation``: (3, 3) turning side b's nodes
    where they touch (a neighbouring sector's face). ``tol`` [m]: the largest distance at
    which two nodes count as coincident.
    """
    surface_a = surface_of(mesh.body_cells(body_a), np.asarray(set_a))
    if not len(surface_a.nodes):
        raise ValueError(f"node set of body {body_a!r}: no face of the body lies in it")
    nodes_a, areas, normals = nodal_areas_and_normals(mesh.points, surface_a)
    k = len(nodes_a)
    if body_b is None:
        return SurfacePairing(nodes_a, np.empty(0, np.int64), sp.csr_matrix((k, 0)), normals,
                              areas, np.zeros(k), np.zeros(k), True)
    surface_b = surface_of(mesh.body_cells(body_b), np.asarray(set_b))
    if not len(surface_b.nodes):
        raise ValueError(f"node set of body {body_b!r}: no face of the body lies in it")
    xyz_b = mesh.points if rotation is None else mesh.points @ np.asarray(rotation).T
    nodes_b = surface_b.nodes
    xa = mesh.points[nodes_a]
    dist, nearest = cKDTree(xyz_b[nodes_b]).query(xa)
    if len(nodes_b) == k and dist.max() <= tol and len(np.unique(nearest)) == k:
        weights = sp.csr_matrix((np.ones(k), (np.arange(k), nearest)), shape=(k, len(nodes_b)))
        return SurfacePairing(nodes_a, nodes_b, weights, normals, areas, np.zeros(k),
                              np.zeros(k), True)
    where = project(xa, xyz_b, surface_b)
    (rows, nodes, values), _ = interpolation(surface_b, where)
    weights = sp.csr_matrix((values, (rows, np.searchsorted(nodes_b, nodes))),
                            shape=(k, len(nodes_b)))
    partner = weights @ xyz_b[nodes_b]
    gaps = np.einsum("ij,ij->i", partner - xa, normals)
    return SurfacePairing(nodes_a, nodes_b, weights, normals, areas, gaps,
                          where.gap - where.distance, False)
