"""The contact grid apart from the mesh: each contact point stands for a cell of a finer
surface mesh and moves with it.

A structured contact face (a planar rectangle ``origin + s e1 + t e2``, s, t in [0, 1]) is
cut into n1 x n2 equal cells; the face is meshed finer, its element edges on the cell
borders (so every facet lies in one cell). Contact point (i, j) is the cell's average:

    u_ij = sum_k w_k u_k,   w_k = int_cell N_k dA / A_cell   (N_k: node k's shape function),

at the cell's centre (the same average of the node positions: a linear field is read
exactly there). Its force F goes back to the nodes as w_k F, so a uniform pressure p
(F = p A_cell at every point) arrives as p int N_k dA: the consistent nodal loads of the
linear facets, as if the pressure acted on the fine mesh. The nodes are the mesh's
vertices (N_k their linear shape functions): with quadratic elements the averages hold the
vertex DOFs, and a uniform pressure reaches the vertices, not the mid-edge DOFs its
quadratic consistent loads would (statically the same; locally, within a fine cell).
Every point holds A / (n1 n2) of the contact's stiffness.
The weights live in the mesh (``Mesh.averages``); the reduction makes the averaged points
masters (``fe.craig_bampton``, ``averaged=``).

Named surfaces of any mesh (an imported deck's) get the same choice by a spacing
(:func:`averaged_surfaces`): side a's contact nodes are gathered into patches about that
wide (spacing^2 each on average; farthest-point seeds, then Lloyd's sweeps: compact, of
even size on any surface), and
each patch is one point on each side, averaged over the part of the surfaces its nodes'
shape functions cover (``pairing.patch_weights``: consistent on both sides, non-matching
meshes included).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from .boundaries import AveragedContact, ContactPatch, SurfaceContact
from .mesh import Mesh, rotation_z
from .pairing import OUTSIDE, nodal_areas_and_normals, paired_contact, patch_weights
from .params import GeometryBuildError
from .surfaces import Surface, surface_of

#: The least length of a patch's mean unit normal: below it (its nodes' normals spread
#: over more than ~120 degrees) the patch spans faces round a sharp edge or a tight bend.
TURN = 0.5


def cells_per_edge(length: float, cells: int, size: float) -> int:
    """Elements along an edge of ``length`` [m] cut into ``cells`` contact cells, at most
    ``size`` [m] long, a whole number per cell (their edges on the cell borders)."""
    return cells * max(1, math.ceil(length / (cells * size) - 1e-9))


def cell_of_facets(points: np.ndarray, surface: Surface, rect, n1: int, n2: int
                   ) -> tuple[Surface, np.ndarray]:
    """(facets, (F,) cell index i n2 + j) of a face's facets on the n1 x n2 cells of
    ``rect = (origin, e1, e2, ...)``; GeometryBuildError where a facet crosses a cell
    border (the mesh is not aligned with the cells)."""
    origin, e1, e2 = (np.asarray(v, float) for v in rect[:3])
    facets = [f for f in (surface.triangles, surface.quads) if len(f)]
    corners = [points[f] - origin for f in facets]  # (F, c, 3) each
    out = []
    for rel in corners:
        s = rel @ e1 / (e1 @ e1) * n1
        t = rel @ e2 / (e2 @ e2) * n2
        i = np.clip(np.floor(s.mean(axis=1)), 0, n1 - 1).astype(np.int64)
        j = np.clip(np.floor(t.mean(axis=1)), 0, n2 - 1).astype(np.int64)
        tol = 1e-6
        inside = ((s >= i[:, None] - tol) & (s <= i[:, None] + 1 + tol)
                  & (t >= j[:, None] - tol) & (t <= j[:, None] + 1 + tol))
        if not inside.all():
            raise GeometryBuildError(f"contact face: a facet crosses a border of the {n1} x "
                                     f"{n2} contact cells (the mesh is not aligned with them)")
        out.append(i * n2 + j)
    return surface, np.concatenate(out)


def cell_averages(points: np.ndarray, surface: Surface, cell: np.ndarray, n_cells: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(rows, nodes, weights) (a,) and positions (n_cells, 3) [m] of the cells' averages:
    row c holds w_k = int_cell N_k dA / A_cell of the nodes of the facets in cell c
    (``cell`` (F,), triangles first, then quads, as ``surface`` lists them)."""
    n_tri = len(surface.triangles)
    rows, nodes, weights = [], [], []
    xyz = np.zeros((n_cells, 3))
    for c in range(n_cells):
        mine = np.flatnonzero(cell == c)
        tri, quad = mine[mine < n_tri], mine[mine >= n_tri] - n_tri
        part = Surface(surface.triangles[tri].reshape(-1, 3), surface.quads[quad].reshape(-1, 4))
        if not len(part.nodes):
            raise GeometryBuildError(f"contact cell {c}: no facet of the face lies in it")
        k, area, _ = nodal_areas_and_normals(points, part)
        w = area / area.sum()
        rows.append(np.full(len(k), c))
        nodes.append(k)
        weights.append(w)
        xyz[c] = w @ points[k]
    return np.concatenate(rows), np.concatenate(nodes), np.concatenate(weights), xyz


def averaged_patch(name: str, points: np.ndarray, first: int,
                   sides: tuple[tuple[str, dict, np.ndarray], tuple[str, dict, np.ndarray]],
                   rect, n1: int, n2: int, b_angle: float = 0.0, b_sector_offset: int = 0
                   ) -> tuple[ContactPatch, np.ndarray, np.ndarray, np.ndarray]:
    """A contact patch of n1 x n2 averaged points on each side.

    sides: ((body, cells, face nodes), ...) of side a and side b (cells: the body's
    elements by shape, as ``Mesh.body_cells``); rect = (origin, e1, e2, normal) in side
    a's (assembled) position; side b's face is its image turned by ``b_angle``. New points
    are numbered from ``first``. Returns (patch, new points (2 n1 n2, 3), averages (a, 2),
    weights (a,)).
    """
    origin, e1, e2, normal = (np.asarray(v, float) for v in rect)
    rot = rotation_z(-b_angle)  # side b's own face
    k = n1 * n2
    new, pairs, weights, grids = [], [], [], []
    for side, (_, cells, face) in enumerate(sides):
        r = (origin, e1, e2) if side == 0 else (rot @ origin, rot @ e1, rot @ e2)
        surface, cell = cell_of_facets(points, surface_of(cells, face), r, n1, n2)
        rows, nodes, w, xyz = cell_averages(points, surface, cell, k)
        ids = first + side * k + np.arange(k)
        new.append(xyz)
        pairs.append(np.column_stack([ids[rows], nodes]))
        weights.append(w)
        grids.append(ids.reshape(n1, n2))
    area = float(np.linalg.norm(np.cross(e1, e2)))
    patch = ContactPatch(name, sides[0][0], sides[1][0], grids[0], grids[1], normal, area,
                         b_sector_offset)
    return patch, np.vstack(new), np.vstack(pairs), np.concatenate(weights)


def face_nodes(n1: int, n2: int, e1: np.ndarray, e2: np.ndarray, size: float
               ) -> tuple[int, int]:
    """Nodes of a contact face's structured mesh along e1 and e2 [m]: the contact grid's
    (``size`` 0), or a finer mesh at ``size`` [m] whose edges lie on the cells' borders."""
    if size <= 0.0:
        return n1, n2
    return (cells_per_edge(float(np.linalg.norm(e1)), n1, size) + 1,
            cells_per_edge(float(np.linalg.norm(e2)), n2, size) + 1)


class ContactGrids:
    """The structured contact patches of a parametric model as its mesh is read: node grids
    (``size`` 0: the contact grid is the mesh) or averaged points over a finer mesh."""

    def __init__(self, points: np.ndarray, size: float) -> None:
        self.points, self.size = points, float(size)
        self._averages: list[np.ndarray] = []
        self._weights: list[np.ndarray] = []

    def patch(self, name: str, side_a: tuple[str, dict, np.ndarray],
              side_b: tuple[str, dict, np.ndarray], rect, n1: int, n2: int,
              b_angle: float = 0.0, b_sector_offset: int = 0) -> ContactPatch:
        """The patch of faces ``side_a``/``side_b`` = (body, cells, face nodes) on
        ``rect = (origin, e1, e2, normal)``."""
        if self.size <= 0.0:
            from ._gmsh import contact_patch

            return contact_patch(name, self.points, side_a[0], side_a[2], side_b[0],
                                 side_b[2], rect, n1, n2, b_angle, b_sector_offset)
        patch, xyz, rows, w = averaged_patch(name, self.points, len(self.points),
                                             (side_a, side_b), rect, n1, n2, b_angle,
                                             b_sector_offset)
        self.points = np.vstack([self.points, xyz])
        self._averages.append(rows)
        self._weights.append(w)
        return patch

    def mesh_fields(self) -> dict:
        """The Mesh fields the patches add: points, averages, average_weights."""
        return {"points": self.points,
                "averages": (np.vstack(self._averages) if self._averages
                             else np.empty((0, 2), np.int64)),
                "average_weights": (np.concatenate(self._weights) if self._weights
                                    else np.empty(0))}


def patch_sets(patch: ContactPatch) -> tuple[np.ndarray, np.ndarray]:
    """The node sets "contact/<name>/<body>" of a patch: its points on side a and side b,
    sorted."""
    return np.sort(patch.nodes_a.ravel()), np.sort(patch.nodes_b.ravel())


def surface_patches(xyz: np.ndarray, areas: np.ndarray, spacing: float,
                    normals: np.ndarray | None = None, sweeps: int = 8) -> np.ndarray:
    """(k,) patch index of each of k surface nodes ``xyz`` (k, 3) [m] with tributary
    ``areas`` (k,) [m^2]: patches of spacing^2 on average (the total area over spacing^2 of
    them, as a square grid of that spacing would cut), about ``spacing`` [m] wide. Seeds by
    farthest points, then Lloyd's sweeps (each node to the nearest seed, each seed to its
    patch's area centre); patch indices ordered along the seeds' coordinates
    (deterministic). With the nodes' unit ``normals`` (k, 3) the distance also counts
    spacing x their turn (|n_i - n_j|): a patch keeps to one face of a sharp edge (a right
    angle puts the other face 1.4 spacings further away)."""
    k = len(xyz)
    count = min(k, max(1, round(areas.sum() / spacing**2)))
    at = xyz if normals is None else np.hstack([xyz, spacing * np.asarray(normals)])
    centre = areas @ at / areas.sum()
    seeds = [int(np.argmax(np.linalg.norm(at - centre, axis=1)))]
    dist = np.linalg.norm(at - at[seeds[0]], axis=1)
    while len(seeds) < count:
        seeds.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(at - at[seeds[-1]], axis=1))
    centres = at[seeds]
    for _ in range(sweeps):
        label = cKDTree(centres).query(at)[1]
        used = np.unique(label)
        mass = np.bincount(label, areas, len(centres))[used]
        centres = np.stack([np.bincount(label, areas * at[:, d], len(centres))[used]
                            for d in range(at.shape[1])], axis=1) / mass[:, None]
    label = cKDTree(centres).query(at)[1]
    used, label = np.unique(label, return_inverse=True)
    order = np.lexsort(centres[used, :3].T[::-1])  # by x, then y, then z
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[label]


def touching_facets(surface: Surface, touching: np.ndarray) -> np.ndarray:
    """(F, 4) mesh nodes of the facets of ``surface`` whose every corner is ``touching``
    ((k,) bool over ``surface.nodes``; a triangle's 4th corner -1): the part of side a an
    averaged contact's map draws, each node's share in its patch's colour."""
    faces = surface.facets
    return faces[np.isin(faces, np.append(surface.nodes[touching], -1)).all(axis=1)]


def averaged_surfaces(mesh: Mesh, name: str, spacing: float) -> Mesh:
    """``mesh`` with its :class:`~.boundaries.SurfaceContact` ``name`` made an
    :class:`~.boundaries.AveragedContact` of points about ``spacing`` [m] apart: side a's touching
    nodes gathered into patches (:func:`surface_patches`), each patch a pair of averaged
    points (``pairing.patch_weights``), new points of the mesh with their averages.
    ValueError naming the contact where it is not between named surfaces (or averaged
    already), or a patch lies wholly beyond the other surface."""
    c = mesh.contacts[name]
    if not isinstance(c, SurfaceContact):
        raise ValueError(f"contacts.{name}: spacing applies to named surfaces only")
    pc = paired_contact(mesh, name)
    surface_a = pc.facets
    nodes_a, whole, normals_a = nodal_areas_and_normals(mesh.points, surface_a)
    touching = np.isin(nodes_a, pc.pairing.nodes_a)
    group = np.full(len(nodes_a), -1)
    group[touching] = surface_patches(mesh.points[nodes_a[touching]], whole[touching],
                                      spacing, normals_a[touching])
    surface_b, xyz_b, outside = None, None, 0.0
    if c.body_b is not None:
        surface_b = surface_of(mesh.body_cells(c.body_b), mesh.node_sets[c.set_b])
        turn = np.eye(3) if not c.b_sector_offset else rotation_z(
            c.b_sector_offset * mesh.cyclic[c.body_b].angle)
        xyz_b = mesh.points @ turn.T
        size = float(np.linalg.norm(np.ptp(xyz_b[surface_b.nodes], axis=0)))
        outside = c.tolerance or OUTSIDE * size
    try:
        Wa, Wb, areas = patch_weights(mesh.points, surface_a, xyz_b, surface_b, group,
                                      outside)
    except ValueError as err:
        raise ValueError(f"contacts.{name}: {err}") from None
    first, g = len(mesh.points), len(areas)
    points, rows, weights = [mesh.points], [mesh.averages], [mesh.average_weights]
    sides = [(Wa, nodes_a)] + ([] if Wb is None else [(Wb, surface_b.nodes)])
    for side, (W, nodes) in enumerate(sides):
        W = W.tocoo()
        keep = W.data > 0.0
        ids = first + side * g + np.arange(g)
        rows.append(np.column_stack([ids[W.row[keep]], nodes[W.col[keep]]]))
        weights.append(W.data[keep])
        points.append(W.tocsr() @ mesh.points[nodes])
    normals = Wa @ normals_a
    length = np.linalg.norm(normals, axis=1)
    if length.min() < TURN:
        i = int(np.argmin(length))
        at = ", ".join(f"{1e3 * v:.4g}" for v in points[1][i])
        raise ValueError(f"contacts.{name}: spacing = {spacing:g} m puts a patch over faces "
                         f"turned too far apart at ({at}) mm: a smaller spacing keeps each "
                         "patch on one face")
    normals /= length[:, None]
    xa = points[1]
    gaps = (np.zeros(g) if Wb is None
            else np.einsum("ij,ij->i", Wb @ xyz_b[surface_b.nodes] - xa, normals))
    faces = touching_facets(surface_a, touching)
    contact = AveragedContact(
        name, c.body_a, c.body_b, first + np.arange(g),
        first + g + np.arange(g) if Wb is not None else np.empty(0, np.int64), normals,
        areas, gaps, faces, group[np.searchsorted(nodes_a, np.unique(faces[faces >= 0]))],
        c.b_sector_offset, c.spread, spacing, c.set_a, c.set_b or "", *pc.dropped)
    return replace(mesh, points=np.vstack(points), averages=np.vstack(rows),
                   average_weights=np.concatenate(weights),
                   contacts={**mesh.contacts, name: contact})
