"""Element quality of linear tetrahedra, computed from coordinates alone (no Gmsh)."""

from __future__ import annotations

import numpy as np

# Edge vectors of the regular unit tetrahedron (columns): the reference shape.
_REGULAR = np.array(
    [[1.0, 0.5, 0.5], [0.0, np.sqrt(3) / 2, np.sqrt(3) / 6], [0.0, 0.0, np.sqrt(2.0 / 3.0)]]
)
_REGULAR_INV = np.linalg.inv(_REGULAR)


def sicn(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(m,) signed inverse condition number of each tet, in [-1, 1].

    SICN = sign(det T) / kappa(T), kappa = |T|_F |T^-1|_F / 3, with T = A W^-1 the map
    from the regular tetrahedron W to the element's edge matrix A (Knupp's condition
    number quality; invariant to size, rotation and vertex order). 1 for a regular tet,
    -> 0 for slivers and needles, < 0 for inverted elements.

    points: (n, 3) m; tets: (m, 4) node indices.
    """
    p = np.asarray(points)[np.asarray(tets)]
    a = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]], axis=2)
    t = a @ _REGULAR_INV
    det = np.linalg.det(t)
    t_inv_norm = np.linalg.norm(np.linalg.inv(t), axis=(1, 2))
    kappa = np.linalg.norm(t, axis=(1, 2)) * t_inv_norm / 3.0
    return np.sign(det) / kappa
