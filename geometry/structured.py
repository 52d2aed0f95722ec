"""Structured meshes in every element shape, without Gmsh: reference models for the element
checks and benchmarks (``bench elements``) and the import and cyclic-face tests.

A box [0, L] x [0, W] x [0, H] on an (nx, ny, nz) grid of cells, each cell a hexahedron,
two wedges (its bottom and top split along the diagonal from corner 0 to 2, the same in
every cell, so neighbours conform) or six tetrahedra (Kuhn's split along the diagonal 0-6,
conforming likewise). ``distort`` moves the interior nodes at random (elements stay valid
for distort < 0.5). A ring sector maps the same grid to (r, theta, z).
"""

from __future__ import annotations

import numpy as np

from . import elements
from .mesh import Mesh

# cell corners (VTK order) -> two wedges / six tetrahedra, positively oriented
_WEDGES = [[0, 1, 2, 4, 5, 6], [0, 2, 3, 4, 6, 7]]
_TETS = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]


def grid(size: tuple[float, float, float], cells: tuple[int, int, int], distort: float = 0.0,
         seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3) [m], hexahedra (m, 8)) of the box ``size`` = (L, W, H) on ``cells`` =
    (nx, ny, nz); interior nodes moved by up to ``distort`` x the cell size."""
    (L, W, H), (nx, ny, nz) = size, cells
    x, y, z = (np.linspace(0, s, n + 1) for s, n in zip(size, cells, strict=True))
    P = np.stack(np.meshgrid(x, y, z, indexing="ij"), axis=-1).reshape(-1, 3)
    ids = np.arange(len(P)).reshape(nx + 1, ny + 1, nz + 1)
    if distort:
        h = np.array([L / nx, W / ny, H / nz])
        inner = ((P > 1e-12) & (P < np.array(size) - 1e-12)).all(axis=1)
        rng = np.random.default_rng(seed)
        P[inner] += distort * h * rng.uniform(-1, 1, (inner.sum(), 3))
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz),
                                               indexing="ij"))
    hexes = np.stack([ids[i, j, k], ids[i + 1, j, k], ids[i + 1, j + 1, k], ids[i, j + 1, k],
                      ids[i, j, k + 1], ids[i + 1, j, k + 1], ids[i + 1, j + 1, k + 1],
                      ids[i, j + 1, k + 1]], axis=1)
    return P, hexes


def split_cells(shape: str, hexes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tetrahedra, hexahedra, wedges) of the hexahedral cells (m, 8) made ``shape``: kept,
    split into two wedges or into six tetrahedra each (conforming between neighbours)."""
    none4, none6, none8 = (np.empty((0, k), dtype=np.int64) for k in (4, 6, 8))
    if shape == "wedge":
        return none4, none8, hexes[:, _WEDGES].reshape(-1, 6)
    if shape == "tetra":
        return hexes[:, _TETS].reshape(-1, 4), none8, none6
    if shape != "hexahedron":
        raise ValueError(f"shape = {shape!r}: expected 'tetra', 'hexahedron' or 'wedge'")
    return none4, hexes, none6


def block(shape: str, size: tuple[float, float, float] = (1.0, 0.1, 0.1),
          cells: tuple[int, int, int] = (10, 2, 2), distort: float = 0.0,
          mixed: bool = False) -> Mesh:
    """A one-body Mesh ("block") of the box in ``shape`` ("hexahedron", "wedge", "tetra");
    ``mixed``: the cells with x < L / 2 hexahedra, the others two wedges each. Node sets:
    "block/clamp" (x = 0), "block/tip" (x = L)."""
    P, hexes = grid(size, cells, distort)
    if mixed:
        right = P[hexes].mean(axis=1)[:, 0] > size[0] / 2
        tets, _, wedges = split_cells("wedge", hexes[right])
        hexes = hexes[~right]
    else:
        tets, hexes, wedges = split_cells(shape, hexes)
    n = len(tets) + len(hexes) + len(wedges)
    sets = {"block/clamp": np.flatnonzero(P[:, 0] < 1e-12),
            "block/tip": np.flatnonzero(P[:, 0] > size[0] - 1e-12)}
    return Mesh("block", P, tets, {"block": np.arange(n)}, node_sets=sets, hexahedra=hexes,
                wedges=wedges)


def annulus(shape: str = "hexahedron", sectors: int = 12,
            cells: tuple[int, int, int] = (3, 4, 2), stretch: float = 0.0,
            radii: tuple[float, float] = (0.1, 0.2), width: float = 0.02,
            curved: bool = False) -> Mesh:
    """One sector (theta in [-phi/2, phi/2]) of a ring r in ``radii``, z in [0, width], on an
    (nr, ntheta, nz) grid of cells in ``shape``; ``stretch`` > 0 moves the radial and axial
    grid lines more the nearer they are to the right face, so the two cyclic faces no longer
    match; ``curved``: every edge's mid node on the cylinder through its ends' mean radius
    (an arc's midpoint along theta), the quadratic geometry a curved deck has. Body "ring";
    node sets "ring/bore" (r = r0), "cyclic/left", "cyclic/right"."""
    P, hexes = grid((1.0, 1.0, 1.0), cells)

    def ring(q: np.ndarray) -> np.ndarray:
        x, t, z = q.T  # unit cube coordinates
        bend = stretch * t * x * (1 - x)  # 0 on the left face (t = 0) and on r0, r1
        r = radii[0] + (radii[1] - radii[0]) * (x + bend)
        theta = (t - 0.5) * 2 * np.pi / sectors
        zz = width * (z + stretch * t * z * (1 - z))
        return np.stack([r * np.cos(theta), r * np.sin(theta), zz], axis=1)

    tets, hexes, wedges = split_cells(shape, hexes)
    n = len(tets) + len(hexes) + len(wedges)
    x, t = P[:, 0], P[:, 1]
    sets = {"ring/bore": np.flatnonzero(x < 1e-12), "cyclic/left": np.flatnonzero(t < 1e-12),
            "cyclic/right": np.flatnonzero(t > 1 - 1e-12)}
    edges = np.empty((0, 2), dtype=np.int64)
    if curved:
        shapes = {"tetra": tets, "hexahedron": hexes, "wedge": wedges}
        edges = np.unique(np.concatenate([np.sort(c[:, elements.EDGES[k]].reshape(-1, 2),
                                                  axis=1) for k, c in shapes.items()]), axis=0)
    points = ring(P)
    return Mesh("annulus", points, tets, {"ring": np.arange(n)}, node_sets=sets,
                hexahedra=hexes, wedges=wedges, curved_edges=edges,
                edge_nodes=_on_mean_cylinder(points[edges]))


def _on_mean_cylinder(ends: np.ndarray) -> np.ndarray:
    """(e, 3) mid-edge points of edges with ``ends`` (e, 2, 3) [m]: the chord's midpoint
    moved radially (about z) onto the cylinder through the ends' mean radius, as a mesher
    projects onto a curved surface: an arc's midpoint for an edge along theta, the chord's
    for a radial or axial one, a second-order offset on a cell's diagonal."""
    mid = ends.mean(axis=1)
    radius = np.linalg.norm(ends[:, :, :2], axis=2).mean(axis=1)
    mid[:, :2] *= (radius / np.linalg.norm(mid[:, :2], axis=1))[:, None]
    return mid
