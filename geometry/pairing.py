"""Two surfaces in contact, paired node by node: what a contact between any two named
surfaces needs from the mesh (Firrone & Zucca 5.2's node-to-node contact, generalized to
surfaces meshed independently).

Side a is the finer surface (more nodes); each of its nodes is a contact point:

* matching surfaces (every a-node has a coincident b-node): the pairs, node for node;
* otherwise node to surface, weighted over the node's tributary area (a mortar
  coupling): the a-node's partner displacement is side b's averaged with the node's own
  shape function, ``u_b'(i) = int N_i^a u_b dA / int N_i^a dA``; side b's displacement at a
  point of side a is interpolated with the shape functions of the side-b facet the point
  projects onto. The integral runs over side a's facets, each cut into sub-cells with a
  Gauss rule (:data:`SUBCELLS`), every quadrature point projected onto side b. The pair's
  normal gap is measured from the node to its own projection.

Why weighted and not the node's own projection: with stiff contact, the point-wise
coupling (one pass, node to segment) passes a load from side a to side b with the nodal
rule of side a, which is not the consistent load of a uniform pressure on side b; the
pressure then oscillates by 15-30 % from node to node however fine the meshes (measured on
the two-block patch test), where the weighted coupling passes a uniform pressure exactly
but for the quadrature across side b's facet edges (``tests/test_surface_contacts.py``).

Each pair carries side a's tributary area in contact (int N_i dA over the part of the
node's facets that lies on side b: the consistent nodal area, a third of each triangle or a
bilinear quad's share, where side b covers it all) and side a's unit normal there (the
area-weighted mean of its facets' outward normals), pointing from body a into body b. A
node whose facets lie wholly outside side b touches nothing. Side b may be a neighbouring
sector's surface: its nodes are then turned by ``rotation`` before the pairing (the cyclic
phase is the assembly's business).

Every contact of a mesh, a structured :class:`~.boundaries.ContactPatch` or named surfaces
(:class:`~.boundaries.SurfaceContact`), reads downstream as one :class:`PairedContact`
(:func:`paired_contact`); :func:`declare_contact` turns what a case names (two surfaces,
one and the ground, one and the neighbouring sector's) into a :class:`~.boundaries.SurfaceContact`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .boundaries import AveragedContact, ContactPatch, SurfaceContact
from .mesh import Mesh, rotation_z
from .surfaces import (
    Surface,
    interpolation,
    onto_facets,
    project,
    quad_map,
    quad_shapes,
    surface_of,
    triangle_shapes,
)


@dataclass(frozen=True)
class SurfacePairing:
    """Side a's nodes and where they meet side b.

    nodes_a: (k,) side a's nodes (the contact points); nodes_b: (m,) side b's nodes the
    weights refer to; weights: (k, m) CSR, u_b'(i) = sum_j w_ij u_b(j) (each row sums to 1;
    identity rows for matching pairs; a zero row for a node touching nothing); normals:
    (k, 3) unit normals of side a, from body a into body b; areas: (k,) tributary areas in
    contact [m^2] (0: touching nothing); gaps: (k,) [m] normal distance from each a-node to
    its projection on side b (positive: open); outside: (k,) [m] how far that projection
    fell outside side b (0: on it); matching: node-for-node pairs.
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
                  tol: float = 1e-9, outside: float | None = None) -> SurfacePairing:
    """Pair the surface of ``body_a`` in node set ``set_a`` with that of ``body_b`` in
    ``set_b`` (``body_b`` None: the ground; side b is then rigid and the gaps zero).

    The caller picks side a as the finer side. ``rotation``: (3, 3) turning side b's nodes
    where they touch (a neighbouring sector's face). ``tol`` [m]: the largest distance at
    which two nodes count as coincident; ``outside`` [m]: how far beyond side b a point of
    side a may project and still touch it (default :data:`OUTSIDE` x side b's size).
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
    partner, _ = interpolation(surface_b, where)
    point = sp.csr_matrix((partner[2], (partner[0], np.searchsorted(nodes_b, partner[1]))),
                          shape=(k, len(nodes_b)))
    gaps = np.einsum("ij,ij->i", point @ xyz_b[nodes_b] - xa, normals)
    size = float(np.linalg.norm(np.ptp(xyz_b[nodes_b], axis=0)))
    weights, covered = mortar_weights(mesh.points, surface_a, xyz_b, surface_b,
                                      OUTSIDE * size if outside is None else outside)
    return SurfacePairing(nodes_a, nodes_b, weights, normals, covered, gaps,
                          where.gap - where.distance, False)


#: Sub-cells per facet edge in the mortar integrals: side b's shape functions have kinks
#: where its facet edges cross side a's facets, which no Gauss rule integrates exactly; the
#: pressure error of the two-block patch test falls as the sub-cells shrink (see
#: tests/test_surface_contacts.py for the measured figures).
SUBCELLS = 4


def mortar_weights(points: np.ndarray, surface_a: Surface, xyz_b: np.ndarray,
                   surface_b: Surface, outside: float, subcells: int = SUBCELLS
                   ) -> tuple[sp.csr_matrix, np.ndarray]:
    """(weights (k, m) CSR, areas in contact (k,) [m^2]) of side a's nodes (k, sorted) on
    side b's (m, sorted): row i is ``int psi_i N_j^b dA / int N_i dA`` with ``psi_i`` the
    dual (biorthogonal) basis of side a, ``int psi_i N_k dA = delta_ik int N_i dA`` on
    every facet (Wohlmuth's dual mortar), so that each row reproduces a linear field of
    side b exactly and side a's consistent nodal forces of a uniform pressure arrive as
    side b's; a node whose facets side b covers only in part keeps its own shape function
    (``int N_i N_j^b dA / int N_i dA``, the area-weighted mean: stable where the dual one
    is not). Points of side a projecting farther than ``outside`` [m] beyond side b touch
    nothing."""
    q = _mortar_quadrature(points, surface_a, xyz_b, surface_b, outside, subcells)
    standard = (q.shape_w.T @ q.Nb).tocsr()
    area = np.asarray(q.shape_w.sum(axis=0)).ravel()
    covered = np.asarray(standard.sum(axis=1)).ravel()
    whole = covered >= area * (1.0 - 1e-9)
    per_dual = sp.diags(np.where(whole, 1.0 / area, 0.0)) @ (q.dual_w.T @ q.Nb)
    per_own = sp.diags(np.divide(1.0, covered, out=np.zeros(len(covered)),
                                 where=~whole & (covered > 0))) @ standard
    return (per_dual + per_own).tocsr(), covered


@dataclass(frozen=True)
class MortarQuadrature:
    """Side a's facet quadrature (q points) with side b's shape functions there: shape_w,
    dual_w: (q, k) CSR side a's shape functions N_i and dual basis psi_i at each point
    times its weight [m^2] (k: side a's nodes, sorted); shape: (q, k) CSR N_i alone; Nb:
    (q, m) CSR side b's N_j at the points that touch it (zero rows elsewhere; None: the
    ground, which every point touches)."""

    shape_w: sp.csr_matrix
    dual_w: sp.csr_matrix
    shape: sp.csr_matrix
    Nb: sp.csr_matrix | None

    @property
    def touching(self) -> np.ndarray:
        """(q,) bool: the points on side b."""
        if self.Nb is None:
            return np.ones(self.shape.shape[0], bool)
        return np.diff(self.Nb.indptr) > 0


def _mortar_quadrature(points: np.ndarray, surface_a: Surface, xyz_b: np.ndarray | None,
                       surface_b: Surface | None, outside: float, subcells: int = SUBCELLS,
                       inside: bool = False) -> MortarQuadrature:
    """:class:`MortarQuadrature` of side a over side b (``xyz_b`` its turned node positions;
    None with ``surface_b``: the ground); ``inside``: side b read at the nearest point of
    the facet each quadrature point projects onto (its feet within the tolerance beyond
    side b's edge moved onto it: no extrapolated, negative weight)."""
    nodes_a = surface_a.nodes
    at, shape, dual, corners, weight = _facet_quadrature(points, surface_a, subcells)
    q = np.repeat(np.arange(len(at)), corners.shape[1])
    cols = np.searchsorted(nodes_a, corners).ravel()

    def on_a(f):  # (q, k) CSR of per-point values f (q, c) at side a's corners
        return sp.csr_matrix((f.ravel(), (q, cols)), shape=(len(at), len(nodes_a)))

    Nb = None
    if surface_b is not None:
        nodes_b = surface_b.nodes
        where = project(at, xyz_b, surface_b)
        on = (where.gap - where.distance) <= outside
        if inside:
            where = onto_facets(where)
        (rows, nodes, values), _ = interpolation(surface_b, where)
        keep = on[rows]
        Nb = sp.csr_matrix((values[keep], (rows[keep], np.searchsorted(nodes_b, nodes[keep]))),
                           shape=(len(at), len(nodes_b)))
    return MortarQuadrature(on_a(shape * weight[:, None]), on_a(dual * weight[:, None]),
                            on_a(shape), Nb)


def patch_weights(points: np.ndarray, surface_a: Surface, xyz_b: np.ndarray | None,
                  surface_b: Surface | None, group: np.ndarray, outside: float,
                  subcells: int = SUBCELLS
                  ) -> tuple[sp.csr_matrix, sp.csr_matrix | None, np.ndarray]:
    """Averaged contact points over patches of two surfaces.

    Patch c is side a's nodes with ``group`` == c ((k,) over ``surface_a.nodes``, -1: in
    none); it stands for the part of the surfaces under phi_c = sum of their shape
    functions N_i (phi_c sum to 1 where every node is in a patch), where side a touches
    side b. Its point on side a moves as ``int phi_c u_a dA / int phi_c dA`` and its
    partner on side b as ``int phi_c u_b dA / int phi_c dA`` (side b's field at side a's
    projected quadrature points): the same average of both sides, so coincident flat
    surfaces give coincident points (curved ones faceted apart differ by the sag), a
    linear field is read exactly at each point, and a uniform pressure (force p int phi_c
    dA at point c) arrives on each side as its consistent nodal loads. Every weight is
    >= 0 (linear shape functions on both sides; side a's quadrature points within the
    tolerance beyond side b's edge read side b at its edge).

    Returns (Wa (g, k) CSR over ``surface_a.nodes``, Wb (g, m) CSR over
    ``surface_b.nodes`` (None: the ground), areas (g,) [m^2] int phi_c dA over side a where
    it touches side b); rows sum to 1.
    """
    q = _mortar_quadrature(points, surface_a, xyz_b, surface_b, outside, subcells, True)
    member = np.flatnonzero(group >= 0)
    g = int(group.max()) + 1
    G = sp.csr_matrix((np.ones(len(member)), (member, group[member])),
                      shape=(len(group), g))
    phi_w = sp.diags(q.touching.astype(float)) @ (q.shape_w @ G)  # (q, g) phi_c w there
    Wa = (phi_w.T @ q.shape).tocsr()
    areas = np.asarray(Wa.sum(axis=1)).ravel()
    if np.any(areas <= 0.0):
        raise ValueError(f"patch {int(np.argmin(areas))} lies wholly beyond the other surface")
    scale = sp.diags(1.0 / areas)
    Wb = None if q.Nb is None else (scale @ (phi_w.T @ q.Nb)).tocsr()
    return (scale @ Wa).tocsr(), Wb, areas


def _facet_quadrature(points: np.ndarray, surface: Surface, s: int
                      ) -> tuple[np.ndarray, ...]:
    """Quadrature over a surface's facets, each cut into s x s sub-cells: (points (q, 3),
    the facet's shape functions there (q, 4), its dual basis there (q, 4), the facet's
    corner nodes (q, 4), weights (q,) [m^2]); triangles' points first (degree-2 rule per
    sub-triangle; a 4th corner of zero weight pads them), then quads' (2 x 2 Gauss per
    sub-square). The dual basis of a facet is ``D M^-1 N`` with M its consistent mass
    and D = diag(M 1), computed with the same points (exact: degree 2 on triangles, and
    on quads bilinear squared times a linear Jacobian)."""
    parts = []
    for facets, rule, shapes in ((surface.triangles, _sub_triangles, triangle_shapes),
                                 (surface.quads, _sub_squares, quad_shapes)):
        if not len(facets):
            continue
        local, w = rule(s)
        g, c = len(local), facets.shape[1]
        p = np.repeat(points[facets], g, axis=0)  # (f g, c, 3)
        xi = np.tile(local, (len(facets), 1))
        N, _ = shapes(xi, 1)  # (f g, c)
        if c == 3:
            at = np.einsum("nc,nci->ni", N, p)
            jac = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        else:
            at, J = quad_map(p, xi)
            jac = np.linalg.norm(np.cross(J[:, :, 0], J[:, :, 1]), axis=1)
        wt = jac * np.tile(w, len(facets))
        mass = np.einsum("fgc,fgd->fcd", (N * wt[:, None]).reshape(-1, g, c),
                         N.reshape(-1, g, c))
        coef = mass.sum(axis=2)[:, :, None] * np.linalg.inv(mass)  # D M^-1 per facet
        dual = np.einsum("fcd,fgd->fgc", coef, N.reshape(-1, g, c)).reshape(-1, c)
        corners = np.repeat(facets, g, axis=0)
        if c == 3:
            N, dual = (np.column_stack([a, np.zeros(len(a))]) for a in (N, dual))
            corners = np.column_stack([corners, corners[:, 0]])
        parts.append((at, N, dual, corners, wt))
    return tuple(np.concatenate(x) for x in zip(*parts, strict=True))


def _sub_triangles(s: int) -> tuple[np.ndarray, np.ndarray]:
    """(local (g, 2), weights (g,)) over the reference triangle (area 1/2) cut into s^2
    sub-triangles, each with the 3-point rule exact to degree 2."""
    rule = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
    out = []
    for i in range(s):
        for j in range(s - i):
            corners = [np.array([i, j]), np.array([i + 1, j]), np.array([i, j + 1])]
            out.append(corners)
            if i + j < s - 1:
                out.append([np.array([i + 1, j]), np.array([i + 1, j + 1]),
                            np.array([i, j + 1])])
    local = np.array([(c[0] + r[0] * (c[1] - c[0]) + r[1] * (c[2] - c[0])) / s
                      for c in out for r in rule])
    return local, np.full(len(local), 0.5 / (3 * s * s))


def _sub_squares(s: int) -> tuple[np.ndarray, np.ndarray]:
    """(local (g, 2), weights (g,)) over [-1, 1]^2 cut into s^2 sub-squares, each with 2 x 2
    Gauss points."""
    h = 2.0 / s
    centres = -1.0 + h * (np.arange(s) + 0.5)
    g = 0.5 * h / np.sqrt(3.0)
    one = np.concatenate([centres - g, centres + g])
    x, y = np.meshgrid(one, one, indexing="ij")
    return np.column_stack([x.ravel(), y.ravel()]), np.full(x.size, h * h / 4.0)


#: Side a's nodes may lie this share of side b's size (its bounding-box diagonal) from it, in
#: the normal direction, before the two surfaces count as not facing each other.
FACING = 0.05
#: Default outside tolerance, as a share of side b's size: points this far beyond its edge
#: still touch it (a curved edge faceted differently on the two sides).
OUTSIDE = 1e-3


@dataclass(frozen=True)
class PairedContact:
    """One contact of a mesh as its pairs (what the stiffness, the assembly and the maps
    read).

    name; body_a; body_b (None: the ground); b_sector_offset: k, side b is turned by
    ``k phi`` of body b's sectors; pairing: side a's pairs (:class:`SurfacePairing`), the
    nodes touching something; facets: side a's faces, mesh nodes (a map's cells); grid:
    (n1, n2) of a structured patch (pairs row-major), else None; reference: (3,) or (k, 3)
    per pair, the direction the first tangent follows (None: ``normal_frames``' default);
    dropped: side a's nodes left out, touching nothing (their count), and how far beyond
    side b the farthest one projects [m]; owner: averaged points only, (m,) the pair each
    of the facets' nodes (sorted) stands in (None: the facets' nodes are the pairs' own).
    """

    name: str
    body_a: str
    body_b: str | None
    b_sector_offset: int
    pairing: SurfacePairing
    facets: Surface
    grid: tuple[int, int] | None = None
    reference: np.ndarray | None = None
    dropped: tuple[int, float] = (0, 0.0)
    owner: np.ndarray | None = None

    @property
    def frames(self) -> np.ndarray:
        """(k, 3, 3) rows t1, t2, n of each pair (:func:`normal_frames`)."""
        return normal_frames(self.pairing.normals, self.reference)

    def faces(self) -> np.ndarray:
        """(F, 4) side a's facets as indices into the pairs (a triangle's 4th corner -1),
        those whose every corner is a pair (a map's cells)."""
        faces = self.facets.facets
        nodes = self.pairing.nodes_a
        order = np.argsort(nodes)
        faces = faces[np.isin(faces, np.append(nodes, -1)).all(axis=1)]
        index = order[np.searchsorted(nodes, faces, sorter=order)]
        return np.where(faces < 0, -1, index)

    def map_cells(self) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
        """What a map of named surfaces draws: (nodes (m,) side a's mesh nodes, owner (m,)
        the pair each stands in (None: each its own, node pairs), faces (F, 4) indices into
        ``nodes``, a triangle's 4th -1); each facet's corners in their pairs' colours. Node
        pairs: the pairs' own nodes and the facets among them; averaged points: the facets
        they stand for."""
        if self.owner is None:
            return self.pairing.nodes_a, None, self.faces()
        faces, nodes = self.facets.facets, self.facets.nodes
        return nodes, self.owner, np.where(faces < 0, -1, np.searchsorted(nodes, faces))

    def nodes_of(self, body: str) -> np.ndarray:
        """Sorted nodes of ``body`` the contact involves (both sides of a body touching
        its own neighbouring sector)."""
        parts = [self.pairing.nodes_a] if self.body_a == body else []
        if self.body_b == body:
            parts.append(self.pairing.nodes_b)
        return np.unique(np.concatenate(parts)) if parts else np.empty(0, np.int64)


def normal_frames(normals: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
    """(k, 3, 3) frames, rows (t1, t2, n), right-handed and orthonormal, of k unit normals
    (k, 3): t1 is ``reference`` (default: the axis +z, or +x where the normal is nearly
    axial) projected onto each tangent plane; t2 = n x t1."""
    n = np.asarray(normals, dtype=np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    if reference is None:
        axial = np.abs(n[:, 2]) > 0.9
        ref = np.where(axial[:, None], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    else:
        ref = np.broadcast_to(np.asarray(reference, dtype=np.float64), n.shape)
    t1 = ref - np.einsum("ij,ij->i", ref, n)[:, None] * n
    length = np.linalg.norm(t1, axis=1)
    if np.any(length < 1e-6):
        raise ValueError("normal_frames: the reference direction is along a normal")
    t1 /= length[:, None]
    return np.stack([t1, np.cross(n, t1), n], axis=1)


def paired_contact(mesh: Mesh, name: str) -> PairedContact:
    """Contact ``name`` of ``mesh`` as its pairs (ValueError naming it when its surfaces
    do not face each other), computed once per mesh (the reduction's masters, the
    stiffness, the assembly, the maps and the estimate all ask)."""
    key = ("paired", name)
    if key not in mesh.derived:
        c = mesh.contacts[name]
        mesh.derived[key] = (_patch_pairs(mesh, name, c) if isinstance(c, ContactPatch)
                             else _averaged_pairs(c) if isinstance(c, AveragedContact)
                             else _surface_pairs(mesh, c))
    return mesh.derived[key]


def keep_pairs(mesh: Mesh, name: str, pairs: PairedContact) -> None:
    """Give contact ``name`` of ``mesh`` the pairs ``pairs`` (what :func:`paired_contact`
    then returns): a whole disk's copy of a sector's contact keeps the sector's pairs, in
    their order, which its copied per-pair stiffness follows."""
    mesh.derived[("paired", name)] = pairs


def turned_copy(p: PairedContact, name: str, body_a: str, body_b: str | None,
                map_a: np.ndarray, map_b: np.ndarray, angle: float) -> PairedContact:
    """A sector's contact ``p`` on a copy of the sector turned by ``angle`` [rad] about +z
    (a whole disk's): its nodes through ``map_a`` (sector node -> copy node, side a's
    sector) and ``map_b`` (side b's, the sector it touches), its normals and frames turned
    with it, its pairs in ``p``'s order, side b in place (no sector offset)."""
    R = rotation_z(angle)
    q = p.pairing
    pairing = SurfacePairing(map_a[q.nodes_a], map_b[q.nodes_b], q.weights, q.normals @ R.T,
                             q.areas, q.gaps, q.outside, q.matching)
    facets = Surface(map_a[p.facets.triangles], map_a[p.facets.quads])
    # an averaged contact's owner follows its facets' nodes sorted: sorted again here
    owner = None if p.owner is None else p.owner[np.argsort(map_a[p.facets.nodes])]
    return PairedContact(name, body_a, body_b, 0, pairing, facets, p.grid,
                         p.frames[:, 0] @ R.T, p.dropped, owner)


def _patch_pairs(mesh: Mesh, name: str, patch: ContactPatch) -> PairedContact:
    """A structured patch: its grid's pairs node for node, equal areas, one normal, the
    first tangent along the grid's first direction."""
    n1, n2 = patch.shape
    k = n1 * n2
    a = mesh.patch_points(name, "a")
    gaps = ((mesh.patch_points(name, "b") - a) @ patch.normal).ravel()
    pairing = SurfacePairing(patch.nodes_a.ravel(), patch.nodes_b.ravel(),
                             sp.identity(k, format="csr"), np.tile(patch.normal, (k, 1)),
                             np.full(k, patch.area / k), gaps, np.zeros(k), True)
    idx = patch.nodes_a
    quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]],
                     axis=-1).reshape(-1, 4)
    d = (a[-1] - a[0]).mean(axis=0)
    return PairedContact(name, patch.body_a, patch.body_b, patch.b_sector_offset, pairing,
                         Surface(np.empty((0, 3), np.int64), quads), (n1, n2), d)


def _averaged_pairs(c: AveragedContact) -> PairedContact:
    """Averaged points over patches of two surfaces: point for point, its own areas,
    normals and gaps; the map's cells side a's facets it stands for."""
    k = len(c.nodes_a)
    weights = sp.identity(k, format="csr") if c.body_b is not None else sp.csr_matrix((k, 0))
    pairing = SurfacePairing(c.nodes_a, c.nodes_b, weights, c.normals, c.areas, c.gaps,
                             np.zeros(k), True)
    tri = c.faces[:, 3] < 0
    return PairedContact(c.name, c.body_a, c.body_b, c.b_sector_offset, pairing,
                         Surface(c.faces[tri, :3], c.faces[~tri]),
                         dropped=(c.dropped, c.reach), owner=c.owner)


def _surface_pairs(mesh: Mesh, c: SurfaceContact) -> PairedContact:
    rotation = None
    if c.b_sector_offset:
        rotation = rotation_z(c.b_sector_offset * mesh.cyclic[c.body_b].angle)
    set_b = None if c.body_b is None else mesh.node_sets[c.set_b]
    try:
        p = pair_surfaces(mesh, c.body_a, mesh.node_sets[c.set_a], c.body_b, set_b, rotation,
                          outside=c.tolerance or None)
    except ValueError as err:
        raise ValueError(f"contacts.{c.name}: {err}") from None
    facets = surface_of(mesh.body_cells(c.body_a), mesh.node_sets[c.set_a])
    if c.body_b is None:
        return PairedContact(c.name, c.body_a, None, 0, p, facets)
    xyz_b = mesh.points[p.nodes_b] @ (np.eye(3) if rotation is None else rotation).T
    size = float(np.linalg.norm(np.ptp(xyz_b, axis=0)))
    # a node touches side b where some of its tributary area does, and either its own
    # projection lies on side b (within the tolerance) or at least half its area does
    _, whole, _ = nodal_areas_and_normals(mesh.points, facets)
    touching = (p.areas > 0) & ((p.outside <= (c.tolerance or OUTSIDE * size))
                                | (p.areas >= 0.5 * whole))
    if not touching.any():
        raise ValueError(f"contacts.{c.name}: no part of {c.set_a} lies on {c.set_b} "
                         f"(nearest node {p.outside.min():.3g} m beyond its edge): the "
                         "surfaces do not touch")
    dropped = (int((~touching).sum()), float(p.outside[~touching].max(initial=0.0)))
    p = _kept(p, touching)  # (side b cut to the nodes the pairs use: its masters)
    worst = int(np.argmax(np.abs(p.gaps)))
    if abs(p.gaps[worst]) > FACING * size:
        raise ValueError(f"contacts.{c.name}: {c.set_a} and {c.set_b} do not face each "
                         f"other: node {int(p.nodes_a[worst])} is {abs(p.gaps[worst]):.3g} m "
                         f"from {c.set_b} (allowed {FACING:g} x its size, {FACING * size:.3g} "
                         "m)")
    return PairedContact(c.name, c.body_a, c.body_b, c.b_sector_offset, p, facets,
                         dropped=dropped)


def _kept(p: SurfacePairing, keep: np.ndarray) -> SurfacePairing:
    """The pairs ``keep`` (k,) bool of a pairing, side b cut to the nodes they use."""
    w = p.weights[keep]
    used = np.unique(w.indices)
    return SurfacePairing(p.nodes_a[keep], p.nodes_b[used], w[:, used].tocsr(),
                          p.normals[keep], p.areas[keep], p.gaps[keep], p.outside[keep],
                          p.matching)


def surface_body_nodes(mesh: Mesh, body: str, set_name: str) -> np.ndarray:
    """The nodes of ``body``'s faces in node set ``set_name`` (the surface's own nodes)."""
    return surface_of(mesh.body_cells(body), mesh.node_sets[set_name]).nodes


def surface_body(mesh: Mesh, set_name: str) -> list[str]:
    """The bodies with boundary faces in node set ``set_name``."""
    nodes = mesh.node_sets[set_name]
    out = []
    for body in sorted(mesh.bodies):
        s = surface_of(mesh.body_cells(body), nodes)
        if len(s.triangles) or len(s.quads):
            out.append(body)
    return out


def declare_contact(mesh: Mesh, name: str, surfaces: tuple[str, ...],
                    bodies: tuple[str, ...] | None = None, ground: bool = False,
                    neighbour: bool = False, tolerance: float = 0.0, spread: str = "area"
                    ) -> SurfaceContact:
    """The :class:`SurfaceContact` of what a case declares: ``surfaces`` two node-set names
    (or one with ``ground``); ``bodies`` their bodies (default: the one body with faces in
    each set); ``neighbour``: the second surface is the neighbouring sector's, on whichever
    side (+1 or -1 sector) brings it onto the first. Side a is made the finer surface (by
    its faces' nodes; a neighbour contact keeps the cyclic body on side b).
    ``tolerance``, ``spread``: as :class:`~.boundaries.SurfaceContact`'s. ValueError naming the
    contact and what is wrong."""
    pre = f"contacts.{name}"
    want = 1 if ground else 2
    if len(surfaces) != want:
        raise ValueError(f"{pre}.surfaces = {list(surfaces)}: expected {want} node-set "
                         f"name{'s' if want > 1 else ''}"
                         + (" with ground = true" if ground else ""))
    for s in surfaces:
        if s not in mesh.node_sets:
            raise ValueError(f"{pre}.surfaces: {s!r} is not a node set of the mesh")
    if bodies is None:
        found = []
        for s in surfaces:
            owners = surface_body(mesh, s)
            if len(owners) != 1:
                raise ValueError(
                    f"{pre}.surfaces: {s!r} is a face of "
                    + (f"bodies {owners}: say which in bodies = [...]" if owners
                       else "no body (no element face has all its nodes in the set)"))
            found.append(owners[0])
        bodies = tuple(found)
    if len(bodies) != len(surfaces) or any(b not in mesh.bodies for b in bodies):
        raise ValueError(f"{pre}.bodies = {list(bodies)}: expected one body per surface, "
                         f"from {sorted(mesh.bodies)}")
    if ground:
        return SurfaceContact(name, bodies[0], surfaces[0], tolerance=tolerance, spread=spread)
    (a, b), (sa, sb) = bodies, surfaces
    k = 0
    if neighbour:
        if b not in mesh.cyclic:
            raise ValueError(f"{pre}.neighbour: body {b!r} of {sb!r} is not a cyclic sector "
                             "body")
        k = _neighbour_side(mesh, sa, sb, mesh.cyclic[b].angle)
    elif a == b:
        raise ValueError(f"{pre}.surfaces: both on body {a!r}; a body touches itself only "
                         "in the neighbouring sector (neighbour = true)")
    finer_b = len(surface_body_nodes(mesh, b, sb)) > len(surface_body_nodes(mesh, a, sa))
    if finer_b and (not k or a in mesh.cyclic):  # the finer side's nodes pair (side b of a
        a, b, sa, sb, k = b, a, sb, sa, -k     # neighbour contact must stay the cyclic one)
    return SurfaceContact(name, a, sa, b, sb, k, tolerance, spread)


def _neighbour_side(mesh: Mesh, set_a: str, set_b: str, phi: float) -> int:
    """+1 or -1: the sector whose image of ``set_b`` lies nearer ``set_a``."""
    xa = mesh.points[mesh.node_sets[set_a]]
    xb = mesh.points[mesh.node_sets[set_b]]
    dist = [np.median(cKDTree(xb @ rotation_z(k * phi).T).query(xa)[0]) for k in (1, -1)]
    return 1 if dist[0] <= dist[1] else -1
