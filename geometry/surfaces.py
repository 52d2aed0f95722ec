"""Surfaces of a body and points projected onto them (cyclic faces tied by interpolation;
contacts between non-matching surfaces).

A surface is the body's boundary faces whose nodes all belong to a node set: triangles and
quads (normals out of the body). A point projects onto the facet nearest to it; its place
there is the facet's local coordinates:

* triangle (xi, eta): x = (1 - xi - eta) p0 + xi p1 + eta p2, inside when xi, eta >= 0 and
  xi + eta <= 1;
* quad (xi, eta) in [-1, 1]^2: the bilinear map of p0..p3 (counter-clockwise), found by
  Newton's method (a warped quad's nearest point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from . import elements

# bilinear quad: corner signs (xi_i, eta_i), counter-clockwise from (-1, -1)
QUAD_CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


@dataclass(frozen=True)
class Surface:
    """Facets of a surface: (t, 3) triangles and (q, 4) quads, node indices."""

    triangles: np.ndarray
    quads: np.ndarray

    @property
    def nodes(self) -> np.ndarray:
        """Sorted unique nodes of the surface."""
        return np.unique(np.concatenate([self.triangles.ravel(), self.quads.ravel()]))

    @property
    def facets(self) -> np.ndarray:
        """(F, 4) the triangles (4th corner -1), then the quads."""
        parts = [np.column_stack([self.triangles, np.full(len(self.triangles), -1)]),
                 self.quads]
        return np.vstack([f for f in parts if len(f)] or [np.empty((0, 4), np.int64)])


@dataclass(frozen=True)
class Projection:
    """Where each of n points lies on a surface.

    quad: (n,) bool, the facet is a quad (else a triangle); facet: (n,) its index among the
    surface's triangles or quads; local: (n, 2) (xi, eta); distance: (n,) [m] from the
    point to its projection; outside: (n,) [-] how far outside the facet the projection
    fell, in local units (0 inside); gap: (n,) [m] the distance plus how far the foot lies
    beyond the facet (how far the point is from the surface itself).
    """

    quad: np.ndarray
    facet: np.ndarray
    local: np.ndarray
    distance: np.ndarray
    outside: np.ndarray
    gap: np.ndarray


def triangle_shapes(local: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Shape functions at triangle coordinates (n, 2): corners (n, 3), and with order 2 the
    edge midpoints (n, 3) of edges (0, 1), (1, 2), (2, 0)."""
    L = np.stack([1.0 - local[:, 0] - local[:, 1], local[:, 0], local[:, 1]], axis=1)
    if order == 1:
        return L, None
    return L * (2.0 * L - 1.0), 4.0 * L * np.roll(L, -1, axis=1)


def quad_shapes(local: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Shape functions at quad coordinates (n, 2) in [-1, 1]^2: corners (n, 4), and with
    order 2 (8-node serendipity) the edge midpoints (n, 4) of edges (0, 1) .. (3, 0)."""
    s = QUAD_CORNERS
    a = 1.0 + local[:, None, 0] * s[:, 0]
    b = 1.0 + local[:, None, 1] * s[:, 1]
    if order == 1:
        return 0.25 * a * b, None
    corner = 0.25 * a * b * (local[:, None, 0] * s[:, 0] + local[:, None, 1] * s[:, 1] - 1.0)
    xi, eta = local[:, 0], local[:, 1]
    mid = 0.5 * np.stack([(1 - xi**2) * (1 - eta), (1 + xi) * (1 - eta**2),
                          (1 - xi**2) * (1 + eta), (1 - xi) * (1 - eta**2)], axis=1)
    return corner, mid


def interpolation(surface: Surface, where: Projection, order: int = 1
                  ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray],
                             tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """How a field on the surface is interpolated at projected points: ((rows, nodes,
    weights) of the facets' corner functions, (rows, edges (m, 2), weights) of their
    mid-edge functions, empty for order 1). Point i's value is the sum of weight x the value
    at the node, or at the midpoint of the edge, of the same row."""
    corner, middle = ([], [], []), ([], [], [])
    for quad, facets in ((False, surface.triangles), (True, surface.quads)):
        sel = np.flatnonzero(where.quad == quad)
        if not sel.size:
            continue
        corners = facets[where.facet[sel]]  # (n, c)
        n_corner, n_mid = (quad_shapes if quad else triangle_shapes)(where.local[sel], order)
        rows = np.repeat(sel, corners.shape[1])
        for out, keys, values in ((corner, corners.ravel(), n_corner),
                                  (middle, np.stack([corners, np.roll(corners, -1, axis=1)],
                                                    axis=2).reshape(-1, 2), n_mid)):
            if values is not None:
                out[0].append(rows)
                out[1].append(keys)
                out[2].append(values.ravel())

    def joined(parts, width):
        if not parts[0]:
            return (np.empty(0, np.int64), np.empty((0, *width), np.int64), np.empty(0))
        return tuple(np.concatenate(x) for x in parts)

    return joined(corner, ()), joined(middle, (2,))


def surface_of(cells: dict[str, np.ndarray], nodes: np.ndarray) -> Surface:
    """The boundary faces of a body (``cells``: shape -> corners) lying in ``nodes``."""
    tri, quad = elements.boundary_faces(cells)
    return Surface(tri[np.isin(tri, nodes).all(axis=1)], quad[np.isin(quad, nodes).all(axis=1)])


def quad_map(p: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x (n, 3), dx/d(xi, eta) (n, 3, 2)) of bilinear quads p (n, 4, 3) at xi (n, 2)."""
    s = QUAD_CORNERS
    n = 0.25 * (1 + xi[:, None, 0] * s[:, 0]) * (1 + xi[:, None, 1] * s[:, 1])  # (n, 4)
    dn = np.stack([0.25 * s[:, 0] * (1 + xi[:, None, 1] * s[:, 1]),
                   0.25 * s[:, 1] * (1 + xi[:, None, 0] * s[:, 0])], axis=2)  # (n, 4, 2)
    return np.einsum("nc,nci->ni", n, p), np.einsum("nci,ncj->nij", p, dn)


def _on_triangles(x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(local (n, 2), distance (n,)) of points x (n, 3) projected on the planes of
    triangles p (n, 3, 3)."""
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d = x - p[:, 0]
    g = np.stack([np.stack([np.einsum("ni,ni->n", e1, e1), np.einsum("ni,ni->n", e1, e2)], 1),
                  np.stack([np.einsum("ni,ni->n", e2, e1), np.einsum("ni,ni->n", e2, e2)], 1)],
                 axis=1)
    rhs = np.stack([np.einsum("ni,ni->n", d, e1), np.einsum("ni,ni->n", d, e2)], axis=1)
    local = np.linalg.solve(g, rhs[..., None])[..., 0]
    foot = p[:, 0] + local[:, :1] * e1 + local[:, 1:] * e2
    return local, np.linalg.norm(x - foot, axis=1)


def _on_quads(x: np.ndarray, p: np.ndarray, steps: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """(local (n, 2), distance (n,)) of points x (n, 3) projected on bilinear quads p (n, 4,
    3): Gauss-Newton on |x(xi) - x|^2 from the centre (exact in one step for a
    parallelogram)."""
    xi = np.zeros((len(x), 2))
    for _ in range(steps):
        y, J = quad_map(p, xi)
        jtj = np.einsum("nki,nkj->nij", J, J)
        jtr = np.einsum("nki,nk->ni", J, x - y)
        delta = np.linalg.solve(jtj, jtr[..., None])[..., 0]
        xi = xi + delta
        if np.abs(delta).max(initial=0.0) < 1e-13:
            break
    y, _ = quad_map(p, xi)
    return xi, np.linalg.norm(x - y, axis=1)


def _outside(local: np.ndarray, quad: bool) -> np.ndarray:
    """How far local coordinates lie outside their facet (0 inside)."""
    if quad:
        return np.clip(np.abs(local) - 1.0, 0.0, None).max(axis=1)
    xi, eta = local.T
    return np.maximum.reduce([-xi, -eta, xi + eta - 1.0, np.zeros_like(xi)])


def _beyond(local: np.ndarray, p: np.ndarray, quad: bool) -> np.ndarray:
    """(n,) [m] from the foot at ``local`` (n, 2) on facets p (n, c, 3) to the facet: to the
    nearest point of the quad's clipped coordinates, or of the triangle's clipped and
    renormalised barycentric ones (0 inside)."""
    if quad:
        foot, _ = quad_map(p, local)
        inside, _ = quad_map(p, _clipped(local, True))
        return np.linalg.norm(foot - inside, axis=1)
    bary, _ = triangle_shapes(local, 1)
    inside, _ = triangle_shapes(_clipped(local, False), 1)
    return np.linalg.norm(np.einsum("nc,nci->ni", bary - inside, p), axis=1)


def _clipped(local: np.ndarray, quad: bool) -> np.ndarray:
    """Local coordinates (n, 2) moved into their facet: a quad's clipped to [-1, 1], a
    triangle's barycentric ones clipped to >= 0 and renormalised."""
    if quad:
        return np.clip(local, -1.0, 1.0)
    bary, _ = triangle_shapes(local, 1)
    clipped = np.clip(bary, 0.0, None)
    clipped /= clipped.sum(axis=1, keepdims=True)
    return clipped[:, 1:]


def onto_facets(where: Projection) -> Projection:
    """``where`` with every foot moved into its facet (:func:`_clipped`): interpolation
    there weighs the facet's corners by non-negative shape functions (no extrapolation
    beyond a surface's edge)."""
    local = where.local.copy()
    for quad in (False, True):
        sel = where.quad == quad
        local[sel] = _clipped(where.local[sel], quad)
    return Projection(where.quad, where.facet, local, where.distance, where.outside, where.gap)


def _fields(p: Projection) -> tuple[np.ndarray, ...]:
    return (p.quad, p.facet, p.local, p.distance, p.outside, p.gap)


def project(points: np.ndarray, xyz: np.ndarray, surface: Surface, candidates: int = 8
            ) -> Projection:
    """Project ``points`` (n, 3) onto ``surface`` (nodes at ``xyz``): each onto the facet,
    among the ``candidates`` nearest by centroid, it lies closest to (inside first)."""
    points = np.asarray(points, dtype=float)
    best = None
    for quad, facets in ((False, surface.triangles), (True, surface.quads)):
        if len(facets) == 0:
            continue
        centroids = xyz[facets].mean(axis=1)
        k = min(candidates, len(facets))
        _, near = cKDTree(centroids).query(points, k=k)
        near = near.reshape(len(points), k)
        for j in range(k):
            p = xyz[facets[near[:, j]]]
            local, dist = (_on_quads if quad else _on_triangles)(points, p)
            out = _outside(local, quad)
            # rank by the gap: how far the foot lies beyond the facet counts as distance
            trial = Projection(np.full(len(points), quad), near[:, j], local, dist, out,
                               dist + _beyond(local, p, quad))
            if best is None:
                best = trial
                continue
            better = trial.gap < best.gap
            best = Projection(*(np.where(better[:, None] if a.ndim == 2 else better, a, b)
                                for a, b in zip(_fields(trial), _fields(best), strict=True)))
    if best is None:
        raise ValueError("project: the surface has no facet")
    return best
