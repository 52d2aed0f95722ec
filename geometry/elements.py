"""The solid element shapes a :class:`~microslip.geometry.mesh.Mesh` holds, by their corners.

A mesh keeps the corner nodes of each element; whether the finite elements on them are
linear or quadratic is the [reduction] table's ``order`` (the quadratic elements' mid-edge
DOFs sit on the straight edges between the corners). Corner order and orientation:

* ``tetra`` (4): positive when (p1 - p0) x (p2 - p0) . (p3 - p0) > 0.
* ``hexahedron`` (8, VTK/Abaqus order): 0-3 the bottom face, 4-7 the top face above them;
  positive when (p1 - p0) x (p3 - p0) points to the top face.
* ``wedge`` (6, Abaqus/Gmsh order): 0-2 the bottom triangle, 3-5 the top one above them;
  positive when (p1 - p0) x (p2 - p0) points to the top triangle.

An element is valid when the Jacobian of its corner map is positive at every corner (a
tangled or inverted element has one that is not).
"""

from __future__ import annotations

import numpy as np

#: shape name -> corner count, in the order a mesh stores its elements
SHAPES = {"tetra": 4, "hexahedron": 8, "wedge": 6}
#: meshio cell type -> our shape, of the solid elements the importers read
SOLID_TYPES = {
    "tetra": "tetra", "tetra10": "tetra",
    "hexahedron": "hexahedron", "hexahedron20": "hexahedron", "hexahedron27": "hexahedron",
    "wedge": "wedge", "wedge15": "wedge",
}

#: shape -> its edges (corner pairs), in VTK's (and Abaqus') order of the quadratic
#: elements' mid-edge nodes
EDGES = {
    "tetra": [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)],
    "hexahedron": [(0, 1), (1, 2), (2, 3), (0, 3), (4, 5), (5, 6), (6, 7), (4, 7), (0, 4),
                   (1, 5), (2, 6), (3, 7)],
    "wedge": [(0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5), (0, 3), (1, 4), (2, 5)],
}
#: shape -> the corner order of the element's mirror image (the same element, opposite
#: orientation; for the wedge also VTK's corner order)
MIRROR = {"tetra": [0, 2, 1, 3], "hexahedron": [0, 3, 2, 1, 4, 7, 6, 5],
          "wedge": [0, 2, 1, 3, 5, 4]}

# Faces with their normals pointing out of the element (corner indices; quads counter-
# clockwise seen from outside).
_TRIANGLES = {
    "tetra": [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]],
    "hexahedron": [],
    "wedge": [[0, 2, 1], [3, 4, 5]],
}
_QUADS = {
    "tetra": [],
    "hexahedron": [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                   [3, 0, 4, 7]],
    "wedge": [[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]],
}
# Per corner: its neighbours (a, b, c) with (pa - p) . (pb - p) x (pc - p) > 0 when valid.
_CORNER_FRAMES = {
    "tetra": [[1, 2, 3]],
    "hexahedron": [[1, 3, 4], [2, 0, 5], [3, 1, 6], [0, 2, 7], [7, 5, 0], [4, 6, 1],
                   [5, 7, 2], [6, 4, 3]],
    "wedge": [[1, 2, 3], [2, 0, 4], [0, 1, 5], [5, 4, 0], [3, 5, 1], [4, 3, 2]],
}


def empty(shape: str) -> np.ndarray:
    """(0, corners) int64: no elements of ``shape``."""
    return np.empty((0, SHAPES[shape]), dtype=np.int64)


def corner_jacobians(points: np.ndarray, shape: str, cells: np.ndarray) -> np.ndarray:
    """(m, c) determinant of the corner map's edge frame at each corner (m^3); all > 0 for
    a valid element (for a tetrahedron, 6 x its volume).

    points: (n, 3) m; cells: (m, corners) node indices of elements of ``shape``.
    """
    p = np.asarray(points)[np.asarray(cells)]
    frames = np.asarray(_CORNER_FRAMES[shape])
    corner = p[:, : len(frames)]
    d = p[:, frames] - corner[:, :, None, :]
    return np.einsum("mci,mci->mc", d[:, :, 0], np.cross(d[:, :, 1], d[:, :, 2]))


def inverted(points: np.ndarray, shape: str, cells: np.ndarray) -> np.ndarray:
    """(k,) indices of the elements of ``shape`` with a non-positive corner Jacobian."""
    if len(cells) == 0:
        return np.empty(0, dtype=np.int64)
    return np.flatnonzero(corner_jacobians(points, shape, cells).min(axis=1) <= 0.0)


def boundary_faces(cells: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Faces that belong to one element only (the outer surface of a body made of these
    cells): (t, 3) triangles and (q, 4) quads, normals out of the solid."""
    out = []
    for faces_of, width in ((_TRIANGLES, 3), (_QUADS, 4)):
        parts = [np.asarray(c, dtype=np.int64)[:, faces_of[s]].reshape(-1, width)
                 for s, c in cells.items() if len(c) and faces_of[s]]
        if not parts:
            out.append(np.empty((0, width), dtype=np.int64))
            continue
        faces = np.concatenate(parts)
        _, index, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True,
                                    return_counts=True)
        out.append(faces[np.sort(index[count == 1])])
    return out[0], out[1]


def triangulated(triangles: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(t + 2 q, 3) triangles: the triangles, then each quad (a, b, c, d) as (a, b, c) and
    (a, c, d), same orientation."""
    quads = np.asarray(quads, dtype=np.int64)
    halves = np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1).reshape(-1, 3)
    return np.concatenate([np.asarray(triangles, dtype=np.int64).reshape(-1, 3), halves])


# Gauss rules exact for the Jacobian determinant of each corner map (degree 2 per
# variable for the trilinear hexahedron; 2 in the triangle and 2 along the axis for the
# wedge): reference points (q, 3) and weights (q,).
_G = 0.5 / np.sqrt(3.0)
_LINE = np.array([0.5 - _G, 0.5 + _G])
_HEX_X = np.array(np.meshgrid(_LINE, _LINE, _LINE, indexing="ij")).reshape(3, -1).T
_TRI = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
_WEDGE_X = np.array([[x, y, z] for z in _LINE for x, y in _TRI])


def _hex_gradients(X: np.ndarray) -> np.ndarray:
    """(q, 8, 3) reference gradients of the trilinear shape functions (VTK corner order)."""
    signs = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                      [1, 1, 1], [0, 1, 1]])
    f = np.where(signs[None], X[:, None, :], 1.0 - X[:, None, :])  # (q, 8, 3) factors
    s = np.where(signs == 1, 1.0, -1.0)[None]
    grad = np.empty(f.shape)
    grad[..., 0] = s[..., 0] * f[..., 1] * f[..., 2]
    grad[..., 1] = f[..., 0] * s[..., 1] * f[..., 2]
    grad[..., 2] = f[..., 0] * f[..., 1] * s[..., 2]
    return grad


def _wedge_gradients(X: np.ndarray) -> np.ndarray:
    """(q, 6, 3) reference gradients of the wedge's shape functions (triangle x line)."""
    x, y, z = X.T
    lam = np.stack([1.0 - x - y, x, y], axis=1)  # (q, 3)
    dlam = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    grad = np.empty((len(X), 6, 3))
    for k, (h, dh) in enumerate(((1.0 - z, -1.0), (z, 1.0))):
        grad[:, 3 * k:3 * k + 3, :2] = h[:, None, None] * dlam[None]
        grad[:, 3 * k:3 * k + 3, 2] = dh * lam
    return grad


def volumes(points: np.ndarray, shape: str, cells: np.ndarray) -> np.ndarray:
    """(m,) volumes (m^3) of elements of ``shape`` (exact for their corner maps)."""
    p = np.asarray(points)[np.asarray(cells)]
    if shape == "tetra":
        d = p[:, 1:] - p[:, :1]
        return np.einsum("ij,ij->i", d[:, 0], np.cross(d[:, 1], d[:, 2])) / 6.0
    X, w, grads = ((_HEX_X, np.full(8, 1 / 8), _hex_gradients(_HEX_X)) if shape == "hexahedron"
                   else (_WEDGE_X, np.full(6, 1 / 12), _wedge_gradients(_WEDGE_X)))
    jac = np.einsum("mai,qaj->mqij", p, grads)  # (m, q, 3, 3) dx_i / dX_j
    return np.linalg.det(jac) @ w


def _tet10_gradients() -> np.ndarray:
    """(10, 10, 3): the reference gradients of the 10-node tetrahedron's shape functions
    (corners, then the mid-edge nodes in ``EDGES["tetra"]`` order) at its 10 nodes."""
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    at = np.vstack([corners, [0.5 * (corners[a] + corners[b]) for a, b in EDGES["tetra"]]])
    L = np.column_stack([1.0 - at.sum(axis=1), at])  # (10 points, 4) barycentric
    dL = np.vstack([-np.ones(3), np.eye(3)])  # (4, 3): dL_i / dxi
    G = np.empty((10, 10, 3))
    for i in range(4):  # corners: L (2 L - 1)
        G[:, i] = (4.0 * L[:, i] - 1.0)[:, None] * dL[i]
    for k, (a, b) in enumerate(EDGES["tetra"]):  # mid-edge: 4 L_a L_b
        G[:, 4 + k] = 4.0 * (L[:, b, None] * dL[a] + L[:, a, None] * dL[b])
    return G


def folded_tets(points: np.ndarray, tets: np.ndarray, mids: np.ndarray) -> np.ndarray:
    """(k,) indices of the tetrahedra (m, 4) whose quadratic map, mid-edge nodes ``mids``
    (m, 6, 3) [m] in ``EDGES["tetra"]`` order, has det J <= 0 at one of its ten nodes (a
    curved edge bent across the element)."""
    X = np.concatenate([points[tets], mids], axis=1)  # (m, 10, 3)
    J = np.einsum("mai,paj->mpij", X, _tet10_gradients())
    return np.flatnonzero((np.linalg.det(J) <= 0.0).any(axis=1))
