"""Finite-element assembly: stiffness and mass of 3D isotropic linear elasticity per body.

Quadratic elements by default, on the corner mesh: scikit-fem's ``ElementTetP2``,
``ElementHexS2`` and our ``ElementWedgeS2`` add one DOF triple per mesh edge (a quadratic
file's mid-edge nodes are these DOFs; the importer checks that they sit on the straight
edges). Linear elements (``order=1``) as an option. The elements and quadrature rules of
each shape: ``fe.basis``.

DOF numbering: the three DOFs (x, y, z) of vertex i of the body are ``node_dofs[i]``; the
quadratic elements' edge DOFs follow, ``edge_dofs[e]`` for edge ``edges[e]``. A body of one
shape is numbered as scikit-fem numbers it; a body mixing shapes assembles each shape's
block with scikit-fem and sums the blocks on this numbering, the edge DOFs shared by edge.
Contact and response nodes are mesh vertices and are mapped to DOFs through these explicit
tables, never by a coordinate search.

Units: SI (m, kg, Pa); matrices in N/m and kg.

Loads: ``centrifugal_load`` gives the consistent load vector of the rotation about the disk
axis (+z through the origin), per unit Omega^2 (see its docstring for what is not modelled).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import skfem as fe
from numpy.typing import NDArray
from skfem.helpers import ddot, dot, sym_grad, trace
from skfem.models.elasticity import linear_elasticity

from microslip.geometry import elements as geometry_elements
from microslip.geometry.mesh import mid_edge_points

from . import basis

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

_ORDERS = (1, 2)


class MeshLike(Protocol):
    """The fields of ``geometry.mesh.Mesh`` this stage reads."""

    points: FloatArray  # (n, 3) m
    bodies: Mapping[str, IntArray]  # body -> element indices
    node_sets: Mapping[str, IntArray]  # name -> sorted node indices
    cyclic: Mapping[str, Any]  # body -> CyclicBoundary
    contacts: Mapping[str, Any]  # name -> ContactPatch
    content_hash: str

    def body_cells(self, body: str) -> dict[str, IntArray]: ...  # shape -> corner nodes


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material.

    youngs_modulus: E [Pa]; poisson_ratio: nu [-], -1 < nu < 0.5; density: rho [kg/m^3].
    """

    youngs_modulus: float
    poisson_ratio: float
    density: float

    def __post_init__(self) -> None:
        E, nu, rho = self.youngs_modulus, self.poisson_ratio, self.density
        if not (math.isfinite(E) and E > 0.0):
            raise ValueError(f"youngs_modulus={E!r}: must be a finite positive number [Pa]")
        if not (math.isfinite(nu) and -1.0 < nu < 0.5):
            raise ValueError(
                f"poisson_ratio={nu!r}: must satisfy -1 < nu < 0.5 "
                "(nu = 0.5 is incompressible, outside displacement-based elasticity)"
            )
        if not (math.isfinite(rho) and rho > 0.0):
            raise ValueError(f"density={rho!r}: must be a finite positive number [kg/m^3]")

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + nu)) [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def lame_lambda(self) -> float:
        """First Lame parameter [Pa]."""
        E, nu = self.youngs_modulus, self.poisson_ratio
        return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    def as_tuple(self) -> tuple[float, float, float]:
        return (float(self.youngs_modulus), float(self.poisson_ratio), float(self.density))


@dataclass(frozen=True, eq=False)
class MaterialZones:
    """Several isotropic materials in one body (a deck's part of two materials):
    ``zones`` (material, (k,) sorted mesh element indices) holding each of the body's
    elements once. Where one material is asked for (a contact's flat-punch stiffness, the
    units' plausibility), the zone of most elements answers (``main``)."""

    zones: tuple[tuple[Material, IntArray], ...]

    @property
    def main(self) -> Material:
        return max(self.zones, key=lambda z: len(z[1]))[0]

    @property
    def youngs_modulus(self) -> float:
        return self.main.youngs_modulus

    @property
    def poisson_ratio(self) -> float:
        return self.main.poisson_ratio

    @property
    def density(self) -> float:
        return self.main.density

    def as_tuple(self) -> tuple:
        """The zones' materials and element sets (a cache key's part)."""
        return tuple((m.as_tuple(), hashlib.sha256(np.asarray(e, np.int64).tobytes())
                      .hexdigest()) for m, e in self.zones)

    def of_elements(self, elements: IntArray) -> IntArray:
        """(m,) the zone of each of the mesh elements ``elements``; ValueError if one is in
        none."""
        zone = np.full(len(elements), -1, dtype=np.int64)
        for i, (_, members) in enumerate(self.zones):
            zone[np.isin(elements, members)] = i
        if np.any(zone < 0):
            raise ValueError(f"MaterialZones: element {int(elements[zone < 0][0])} has no "
                             "material")
        return zone


@dataclass(frozen=True, eq=False)
class BodyModel:
    """Assembled stiffness and mass of one body, with its node/DOF tables.

    nodes: (n_v,) global mesh indices of the body's vertices (sorted).
    points: (n_v, 3) their coordinates [m].
    node_dofs: (n_v, 3) DOF indices of each vertex (x, y, z).
    edges: (n_e, 2) global vertex pairs (sorted per row) of the mesh edges.
    edge_dofs: (n_e, 3) DOF indices of the P2 edge nodes (empty for order 1).
    boundary_facets: (n_f, 3) global vertex triples of the body's boundary triangles (a
        quad face as two).
    cells: shape -> (m_s, corners) global vertex indices of the body's elements of that
        shape (mesh order), from which the scikit-fem bases (same DOF numbering) are
        rebuilt for loads.
    stiffness, mass: (N, N) CSR [N/m], [kg].
    curved_edges: (c, 2) global vertex pairs of the body's curved edges, edge_nodes: (c, 3)
        their mid-edge node positions [m] (the mesh's, for the loads' bases).
    """

    body: str
    order: int
    material: Material
    mesh_hash: str
    nodes: IntArray
    points: FloatArray
    node_dofs: IntArray
    edges: IntArray
    edge_dofs: IntArray
    boundary_facets: IntArray
    cells: Mapping[str, IntArray]
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    curved_edges: IntArray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    edge_nodes: FloatArray = field(default_factory=lambda: np.empty((0, 3)))
    zones: Mapping[str, IntArray] = field(default_factory=dict)  # shape -> each row's zone

    @property
    def n_dofs(self) -> int:
        return int(self.stiffness.shape[0])

    def local_nodes(self, nodes: Sequence[int] | IntArray, what: str = "nodes") -> IntArray:
        """Positions in ``self.nodes`` of global node indices; ValueError if one is not here."""
        nodes = np.asarray(nodes, dtype=np.int64).ravel()
        pos = np.searchsorted(self.nodes, nodes)
        pos_c = np.minimum(pos, len(self.nodes) - 1)
        bad = self.nodes[pos_c] != nodes
        if np.any(bad):
            raise ValueError(
                f"{what}: node(s) {nodes[bad][:8].tolist()} are not vertices of body "
                f"{self.body!r} (it has {len(self.nodes)} vertices)"
            )
        return pos_c

    def dofs_of_nodes(self, nodes: Sequence[int] | IntArray, what: str = "nodes") -> IntArray:
        """(k, 3) DOF indices (x, y, z) of global vertex indices ``nodes`` (k,)."""
        return self.node_dofs[self.local_nodes(nodes, what)]

    def edge_index(self, pairs: IntArray) -> IntArray:
        """Indices into ``self.edges`` of vertex pairs (k, 2); -1 where no such edge exists."""
        if len(self.edges) == 0 or len(pairs) == 0:
            return np.full(len(pairs), -1, dtype=np.int64)
        pairs = np.sort(np.asarray(pairs, dtype=np.int64), axis=1)
        base = np.int64(self.nodes[-1] + 1)
        keys = self.edges[:, 0] * base + self.edges[:, 1]
        order = np.argsort(keys)
        query = pairs[:, 0] * base + pairs[:, 1]
        pos = np.minimum(np.searchsorted(keys, query, sorter=order), len(keys) - 1)
        found = keys[order[pos]] == query
        return np.where(found, order[pos], -1)

    def set_facets(self, nodes: IntArray) -> IntArray:
        """(k, 3) boundary triangles whose three vertices all belong to ``nodes``."""
        inside = np.isin(self.boundary_facets, nodes).all(axis=1)
        return self.boundary_facets[inside]

    def set_edges(self, nodes: IntArray) -> IntArray:
        """Indices of the edges of boundary triangles lying entirely in the node set.

        Edges only touching the set, or crossing the interior between two of its vertices, are
        not part of the surface the set describes and are left out.
        """
        facets = self.set_facets(nodes)
        if len(facets) == 0 or len(self.edges) == 0:
            return np.empty(0, dtype=np.int64)
        pairs = np.concatenate([facets[:, [0, 1]], facets[:, [1, 2]], facets[:, [0, 2]]])
        idx = self.edge_index(np.unique(np.sort(pairs, axis=1), axis=0))
        return np.unique(idx[idx >= 0])

    def set_dofs(self, nodes: Sequence[int] | IntArray, what: str = "nodes") -> IntArray:
        """Sorted DOFs of a vertex set: its vertex DOFs plus the P2 edge DOFs on its surface."""
        nodes = np.asarray(nodes, dtype=np.int64).ravel()
        vertex = self.dofs_of_nodes(nodes, what).ravel()
        if len(self.edge_dofs) == 0:  # linear elements: vertex DOFs only
            return np.unique(vertex)
        edge = self.edge_dofs[self.set_edges(nodes)].ravel()
        return np.unique(np.concatenate([vertex, edge]))


def node_set(mesh: MeshLike, name: str) -> IntArray:
    """Sorted global node indices of the named node set; ValueError if it does not exist."""
    if name not in mesh.node_sets:
        if name in getattr(mesh, "parameters", {}).get("dropped_sets", ()):
            raise ValueError(f"node set {name!r} holds mid-side nodes only, which the corner "
                             "mesh drops (the quadratic elements' edge DOFs take their "
                             "place); name a set of corner nodes")
        raise ValueError(
            f"node set {name!r} does not exist; available: {sorted(mesh.node_sets)}"
        )
    return np.asarray(mesh.node_sets[name], dtype=np.int64)


def node_sets_union(mesh: MeshLike, names: Sequence[str]) -> IntArray:
    """Sorted union of several named node sets (global indices)."""
    if isinstance(names, str):
        names = [names]
    parts = [node_set(mesh, n) for n in names]
    return np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.int64)


def _check_order(order: int) -> None:
    if order not in _ORDERS:
        raise ValueError(f"order={order!r}: element order must be 1 (linear) or 2 (quadratic)")


@fe.BilinearForm
def _mass_form(u, v, w):
    return w["rho"] * dot(u, v)


@fe.BilinearForm
def _elasticity_form(u, v, w):
    # 2 mu eps(u) : eps(v) + lambda div u div v, the Lame parameters per quadrature point
    eu, ev = sym_grad(u), sym_grad(v)
    return 2.0 * w["mu"] * ddot(eu, ev) + w["lam"] * trace(eu) * trace(ev)


def _constant(basis: fe.Basis, material: Material | MaterialZones, zone: IntArray | None,
              value: Callable[[Material], float]) -> float | NDArray:
    """A material constant on ``basis``: one number, or with ``zone`` (each element's index
    into ``material.zones``) (elements, points), each element's own."""
    if zone is None:
        return value(material)
    values = np.array([value(m) for m, _ in material.zones])[zone]
    return np.repeat(values[:, None], basis.X.shape[-1], axis=1)


def stiffness(basis: fe.Basis, material: Material | MaterialZones,
              zone: IntArray | None = None) -> sp.csr_matrix:
    """Stiffness matrix K (N, N) [N/m] of isotropic linear elasticity on ``basis``; with
    ``zone`` (each element's index into ``material.zones``), each element's own material."""
    if zone is None:
        form = linear_elasticity(material.lame_lambda, material.shear_modulus)
        return form.assemble(basis).tocsr()
    return _elasticity_form.assemble(
        basis, lam=_constant(basis, material, zone, lambda m: m.lame_lambda),
        mu=_constant(basis, material, zone, lambda m: m.shear_modulus)).tocsr()


def mass(basis: fe.Basis, material: Material | MaterialZones,
         zone: IntArray | None = None) -> sp.csr_matrix:
    """Consistent mass matrix M (N, N) [kg] on ``basis`` (``zone``: as ``stiffness``)."""
    return _mass_form.assemble(
        basis, rho=_constant(basis, material, zone, lambda m: m.density)).tocsr()


@dataclass(frozen=True, eq=False)
class _Block:
    """The elements of one shape in a body: their scikit-fem mesh and where each of its
    DOFs goes in the body's numbering (``dof_map``: block DOF -> body DOF)."""

    shape: str
    mesh: fe.Mesh
    dof_map: IntArray
    mapping: Any = None  # the curved elements' isoparametric map (None: the corner map)

    def basis(self, order: int, degree: int) -> fe.CellBasis:
        return basis.SHAPES[self.shape].basis(self.mesh, order, degree, self.mapping)


def _blocks(points: FloatArray, cells: Mapping[str, IntArray], order: int,
            curved: tuple[IntArray, FloatArray] | None = None
            ) -> tuple[IntArray, IntArray, list[_Block]]:
    """(vertices (n_v,), edges (n_e, 2) sorted global vertex pairs, blocks) of a body.

    Vertex i's DOFs are 3 i + (0, 1, 2); with order 2, edge e's are 3 (n_v + e) + (0, 1, 2)
    (scikit-fem's numbering when the body has one shape). Edges are numbered as the first
    block that has them. ``curved``: (pairs (c, 2), mid-edge nodes (c, 3) [m]) of the
    mesh's curved edges; a block with one of them maps every element through its quadratic
    geometry (straight edges' mid nodes at their midpoints).
    """
    nodes = np.unique(np.concatenate([np.asarray(c).ravel() for c in cells.values()]))
    key_of: dict[tuple[int, int], int] = {}
    blocks = []
    for shape, corners in cells.items():
        kind = basis.SHAPES[shape]
        local = np.searchsorted(nodes, corners)[:, list(kind.to_skfem)]
        used, inverse = np.unique(local, return_inverse=True)
        skm = kind.mesh(np.ascontiguousarray(points[nodes[used]].T),
                        np.ascontiguousarray(inverse.reshape(local.shape).T))
        dof_map = (3 * used[:, None] + np.arange(3)).ravel()
        if order == 2:
            pairs = np.sort(used[skm.edges.T], axis=1)
            index = np.array([key_of.setdefault((int(a), int(b)), len(key_of))
                              for a, b in pairs], dtype=np.int64)
            dof_map = np.concatenate([dof_map, (3 * (len(nodes) + index[:, None])
                                                + np.arange(3)).ravel()])
        mapping = None
        if curved is not None and len(curved[0]):
            pairs = np.sort(nodes[used[skm.edges.T]], axis=1)
            mid = mid_edge_points(points, pairs, *curved)
            if np.abs(mid - points[pairs].mean(axis=1)).max() > 0.0:
                mapping = kind.curved_mapping(skm, mid)
                _check_curved_map(mapping, shape, nodes[used])
        blocks.append(_Block(shape, skm, dof_map.astype(np.int64), mapping))
    edges = np.array(list(key_of), dtype=np.int64).reshape(-1, 2)
    return nodes, nodes[edges] if len(edges) else edges, blocks


class InvertedElements(ValueError):
    """Curved elements whose mid-edge nodes fold their map (det J changes sign)."""


def _check_curved_map(mapping: Any, shape: str, vertices: IntArray) -> None:
    """InvertedElements naming how many elements of ``shape`` the isoparametric map turns
    inside out at one of their nodes (corners or mid-edge: where a far-off mid node shows
    first), and the first one's corners (global vertex numbers ``vertices``)."""
    det = mapping.detDF(np.ascontiguousarray(mapping.elem.doflocs.T))  # (elements, nodes)
    # scikit-fem integrates |det J|, and its hexahedra map with det J < 0: what folds an
    # element is a sign unlike the block's, anywhere on it
    det = det * np.sign(np.median(det))
    bad = np.flatnonzero((det <= 0.0).any(axis=1))
    if bad.size:
        corners = vertices[mapping.mesh.t[: geometry_elements.SHAPES[shape], bad[0]]]
        raise InvertedElements(
            f"{bad.size} curved {shape} element(s) turned inside out by their mid-edge nodes "
            f"(det J changes sign at a node; first: corners {corners.tolist()}): move the mid "
            "nodes nearer their edges' midpoints, or refine where the edges bend")


def _summed(parts: list[tuple[sp.spmatrix, IntArray]], n: int) -> sp.csr_matrix:
    """sum_b P_b^T A_b P_b (n, n): block matrices A_b scattered by their DOF maps."""
    if len(parts) == 1 and np.array_equal(parts[0][1], np.arange(n)):
        return parts[0][0].tocsr()
    rows, cols, vals = [], [], []
    for a, dof_map in parts:
        a = a.tocoo()
        rows.append(dof_map[a.row])
        cols.append(dof_map[a.col])
        vals.append(a.data)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n, n))


def assemble(mesh: MeshLike, body: str, material: Material, order: int = 2) -> BodyModel:
    """Assemble K and M of one body of ``mesh`` (see the module docstring for the choices)."""
    _check_order(order)
    if not isinstance(material, Material | MaterialZones):
        raise ValueError(f"material={material!r}: expected a fem.Material")
    if body not in mesh.bodies:
        raise ValueError(f"body={body!r} does not exist; available: {sorted(mesh.bodies)}")
    cells = mesh.body_cells(body)
    if not cells:
        raise ValueError(f"body={body!r} has no elements")
    points = np.asarray(mesh.points, dtype=np.float64)
    curved = _body_curved_edges(mesh, cells)
    nodes, edges, blocks = _blocks(points, cells, order, curved)
    n = 3 * (len(nodes) + (len(edges) if order == 2 else 0))
    zones = _zones_of(mesh, body, material)
    k_parts, m_parts = [], []
    for block in blocks:
        k_degree, m_degree = basis.SHAPES[block.shape].degrees[order]
        zone = zones.get(block.shape)
        k_parts.append((stiffness(block.basis(order, k_degree), material, zone),
                        block.dof_map))
        m_parts.append((mass(block.basis(order, m_degree), material, zone), block.dof_map))
    K, M = _summed(k_parts, n), _summed(m_parts, n)
    K = ((K + K.T) * 0.5).tocsr()  # remove assembly round-off asymmetry
    M = ((M + M.T) * 0.5).tocsr()
    vertex_dofs = 3 * np.arange(len(nodes))[:, None] + np.arange(3)
    edge_dofs = (3 * (len(nodes) + np.arange(len(edges)))[:, None] + np.arange(3)
                 if order == 2 else np.empty((0, 3), dtype=np.int64))
    return BodyModel(
        body=body,
        order=order,
        material=material,
        mesh_hash=str(getattr(mesh, "content_hash", "")),
        nodes=nodes.astype(np.int64),
        points=points[nodes],
        node_dofs=vertex_dofs.astype(np.int64),
        edges=np.sort(edges, axis=1).astype(np.int64),
        edge_dofs=edge_dofs.astype(np.int64),
        boundary_facets=geometry_elements.triangulated(
            *geometry_elements.boundary_faces(cells)),
        cells={shape: np.asarray(c, dtype=np.int64) for shape, c in cells.items()},
        stiffness=K,
        mass=M,
        curved_edges=curved[0],
        edge_nodes=curved[1],
        zones=zones,
    )


def region_stiffness(mesh: MeshLike, body: str, material: Material | MaterialZones,
                     order: int, elements: IntArray, nominal: BodyModel | None = None
                     ) -> sp.csr_matrix:
    """(n, n) [N/m] over the body's DOFs: the stiffness of the region ``elements`` (mesh
    element indices of ``body``) alone, dK/d(ln E) there (K is linear in E): K with the
    region's Young's modulus doubled, less K (``nominal``, if assembled already). What a
    mistuned blade's per-blade deviation delta scales: K + delta K_region."""
    elements = np.unique(np.asarray(elements, dtype=np.int64))
    index = np.sort(np.asarray(mesh.bodies[body], dtype=np.int64))
    if not len(elements) or not np.all(np.isin(elements, index)):
        raise ValueError(f"region: {len(elements)} elements, not a non-empty subset of body "
                         f"{body!r}'s")
    zones = material.zones if isinstance(material, MaterialZones) else ((material, index),)
    doubled = []
    for m, members in zones:
        twice = Material(2.0 * m.youngs_modulus, m.poisson_ratio, m.density)
        doubled += [(m, np.setdiff1d(members, elements)),
                    (twice, np.intersect1d(members, elements))]
    stiffer = assemble(mesh, body, MaterialZones(tuple((m, e) for m, e in doubled if len(e))),
                       order).stiffness
    base = (nominal if nominal is not None else assemble(mesh, body, material, order)).stiffness
    K = (stiffer - base).tocsr()
    K.data[np.abs(K.data) <= 1e-12 * np.abs(K.data).max()] = 0.0  # the rest cancels exactly
    K.eliminate_zeros()
    return K


def _zones_of(mesh: MeshLike, body: str, material: Material | MaterialZones
              ) -> dict[str, IntArray]:
    """Shape -> the zone of each row of the body's cells of that shape (empty for one
    material): the body's elements, sorted, split by shape as ``body_cells`` splits them."""
    if not isinstance(material, MaterialZones):
        return {}
    index = np.asarray(mesh.bodies[body], dtype=np.int64)
    out, start = {}, 0
    for shape, c in mesh.cells.items():
        inside = index[(index >= start) & (index < start + len(c))]
        if len(inside):
            out[shape] = material.of_elements(inside)
        start += len(c)
    return out


def _body_curved_edges(mesh: MeshLike, cells: Mapping[str, IntArray]
                       ) -> tuple[IntArray, FloatArray]:
    """(pairs (c, 2), mid-edge nodes (c, 3) [m]) of the mesh's curved edges among the
    corners of ``cells`` (a body's)."""
    pairs = np.asarray(getattr(mesh, "curved_edges", np.empty((0, 2))), dtype=np.int64)
    xyz = np.asarray(getattr(mesh, "edge_nodes", np.empty((0, 3))), dtype=np.float64)
    if not len(pairs):
        return pairs.reshape(0, 2), xyz.reshape(0, 3)
    corners = np.unique(np.concatenate([np.asarray(c).ravel() for c in cells.values()]))
    inside = np.isin(pairs, corners).all(axis=1)
    return pairs[inside], xyz[inside]


# --- loads ---------------------------------------------------------------------------------


@fe.LinearForm
def _centrifugal_form(v, w):
    # rho (x, y, 0) . v: the centrifugal body force per unit Omega^2 about the z axis.
    return w["rho"] * (w.x[0] * v[0] + w.x[1] * v[1])


def centrifugal_load(body: BodyModel) -> FloatArray:
    """Consistent FE load vector (N,) [N/(rad/s)^2] of a rotation about the disk axis, per
    unit Omega^2: multiply by Omega^2 [(rad/s)^2] for the load in N at speed Omega [rad/s].

    The disk axis is +z through the origin (every geometry model). The body force density at
    speed Omega is rho Omega^2 (x, y, 0) [N/m^3]; its consistent load is f_i = int rho (x, y, 0)
    . N_i dV, assembled with scikit-fem on the body's own basis (same DOF numbering as K and M).
    The integrand is a shape function (degree p) times a linear field, so ``intorder = p + 1``
    is exact on straight-sided (affine) elements; as the field is linear, f = M g exactly,
    with g the interpolant of (x, y, 0).

    Not modelled: spin softening (the -Omega^2 M_c term of the rotating frame) and stress
    stiffening (the geometric stiffness of the centrifugal prestress): K and M stay those of
    the body at rest, this is the load only.
    """
    if not body.cells:
        raise ValueError(f"body {body.body!r}: no elements to integrate the load over")
    # The same vertices, edges and blocks as in ``assemble``: the same DOF numbering.
    points = np.zeros((int(body.nodes[-1]) + 1, 3))
    points[body.nodes] = body.points
    _, _, blocks = _blocks(points, body.cells, body.order,
                           (body.curved_edges, body.edge_nodes))
    f = np.zeros(body.n_dofs)
    for block in blocks:
        basis = block.basis(body.order, body.order + 1)
        rho = _constant(basis, body.material, body.zones.get(block.shape), lambda m: m.density)
        part = _centrifugal_form.assemble(basis, rho=rho)
        np.add.at(f, block.dof_map, part)
    return np.asarray(f, dtype=np.float64)


# --- damping -------------------------------------------------------------------------------

# a mode is rigid below this share of the largest eigenvalue: rounding on a free body is
# ~1e-16 of it, a soft elastic mode (omega ratio 1e-4 to the stiffest) still 1e-8 above
RIGID_SHARE = 1e-10


@dataclass(frozen=True)
class Damping:
    """Linear (viscous) damping of the structure, added on top of friction.

    rayleigh_alpha [1/s], rayleigh_beta [s]: C = alpha M + beta K.
    modal_ratios: zeta per elastic mode (scalar for all of them, or a sequence for the first
    elastic modes; modes beyond the sequence take its last value), C = M Phi diag(2 zeta omega)
    Phi^H M with Phi the mass-normalised modes of the (reduced) model; rigid-body modes are
    left undamped. Both parts add.
    """

    rayleigh_alpha: float = 0.0
    rayleigh_beta: float = 0.0
    modal_ratios: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name in ("rayleigh_alpha", "rayleigh_beta"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}={value!r}: must be finite and >= 0")
        ratios = self.modal_ratios
        if np.isscalar(ratios):
            object.__setattr__(self, "modal_ratios", (float(ratios),))
        ratios = np.asarray(self.modal_ratios, dtype=float)
        if np.any(~np.isfinite(ratios)) or np.any(ratios < 0.0):
            raise ValueError(f"modal_ratios={self.modal_ratios!r}: must be finite and >= 0")
        object.__setattr__(self, "modal_ratios", tuple(float(r) for r in ratios))

    @property
    def is_zero(self) -> bool:
        return self.rayleigh_alpha == 0 and self.rayleigh_beta == 0 and not any(self.modal_ratios)


def rayleigh_damping(K: Any, M: Any, alpha: float, beta: float) -> Any:
    """C = alpha M + beta K (sparse or dense, same shape as K)."""
    return alpha * M + beta * K


def modal_damping(K: NDArray, M: NDArray, ratios: Sequence[float],
                  modes: tuple[NDArray, NDArray] | None = None) -> NDArray:
    """Dense damping matrix with modal damping ratios on (K, M) (r, r), Hermitian.

    C = M Phi diag(2 zeta_j omega_j) Phi^H M, Phi mass-normalised. Rigid-body modes
    (lam <= RIGID_SHARE * max lam) get no damping, and the ratios go to the elastic modes in
    order: a free body's rigid eigenvalues are rounding (~1e-16 of the largest), and damping
    them would depend on which basis of the rigid subspace the eigensolver returned, so a
    body and its turned copy would differ. ``ratios`` as in ``Damping.modal_ratios``;
    ``modes``: every (lam, Phi) of (K, M) where already known (the rigid threshold is a
    share of the largest eigenvalue: a subset would move it).
    """
    K = np.asarray(K)
    M = np.asarray(M)
    lam, phi = sla.eigh(K, M) if modes is None else map(np.asarray, modes)
    if len(lam) != len(K):
        raise ValueError(f"modal_damping: {len(lam)} modes given of {len(K)}: needs them all")
    ratios = np.asarray(ratios, dtype=float).ravel()
    if ratios.size == 0:
        return np.zeros_like(K)
    elastic = lam > RIGID_SHARE * np.max(lam, initial=0.0)
    n = int(np.count_nonzero(elastic))
    zeta = np.full(n, ratios[-1])
    zeta[: min(len(ratios), n)] = ratios[:n]
    mphi = M @ phi[:, elastic]
    return (mphi * (2.0 * zeta * np.sqrt(lam[elastic]))) @ mphi.conj().T


def damping_matrix(K: NDArray, M: NDArray, damping: Damping | None,
                   modes=None) -> NDArray | None:
    """Dense damping matrix of a (reduced) model from a ``Damping`` spec; None if no damping.
    ``modes``: a callable giving (lam, Phi) of (K, M), asked only for modal ratios."""
    if damping is None or damping.is_zero:
        return None
    C = rayleigh_damping(np.asarray(K), np.asarray(M), damping.rayleigh_alpha,
                         damping.rayleigh_beta)
    if any(damping.modal_ratios):
        C = C + modal_damping(K, M, damping.modal_ratios,
                              None if modes is None else modes())
    return 0.5 * (C + C.conj().T)
