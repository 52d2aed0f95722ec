"""The mesh contract: a plain, immutable, validated data object.

Everything downstream (assembly, cyclic symmetry, reduction, contact) reads a
:class:`Mesh`; nothing downstream ever talks to Gmsh.

Conventions
-----------
* SI units (m). Node and element indices are 0-based ``int64``.
* Disk axis = global +z through the origin. The fundamental sector spans
  ``theta in [-phi/2, +phi/2]`` (measured from +x about +z), ``phi = 2 pi / Ns``,
  so the sector's blade points along +x. Left cyclic face at ``-phi/2``, right
  face at ``+phi/2``; ``right[i]`` is the image of ``left[i]`` under the rotation
  by ``+phi`` about +z.
* Node-set names are "/" paths ("disk/bore", "cyclic/disk/left",
  "contact/root_left/blade", ...); each model documents its names.
* Different bodies share no node; touching faces carry distinct, coincident nodes.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from . import elements
from .boundaries import (
    AveragedContact,
    ContactPatch,
    CyclicBoundary,
    MeshValidationError,
    Support,
    SurfaceContact,
    frozen,
    index_array,
)

#: The Mesh fields holding each element shape, in element-numbering order.
_FIELDS = {"tetrahedra": "tetra", "hexahedra": "hexahedron", "wedges": "wedge"}

#: Geometric matching tolerance of cyclic faces and contact grids (m).
MATCH_TOL = 1e-9
#: A mid-edge node this far off its straight midpoint (relative to the edge's length) makes
#: the edge curved: below it, the deck's or Gmsh's rounding.
CURVED = 1e-6


def rotation_z(angle: float) -> np.ndarray:
    """(3, 3) rotation matrix by ``angle`` (rad) about +z."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Mesh:
    """Solid mesh of one model with bodies, named sets, cyclic faces, contacts.

    model:      model name ("blisk_sector", "root_joint", "beam", "annular_sector",
                "import")
    points:     (n_nodes, 3) float64 node coordinates (m)
    tetrahedra: (n_tets, 4) int64 node indices, positively oriented (see ``cells``)
    bodies:     body name -> (n_body_elements,) int64 element indices; the elements are
                numbered tetrahedra first, then hexahedra, then wedges; bodies partition
                the elements and share no node
    node_sets:  name -> sorted unique int64 node indices
    cyclic:     body name -> its :class:`CyclicBoundary` (sector bodies only)
    contacts:   contact name -> :class:`ContactPatch` (a structured grid, node for node),
                :class:`SurfaceContact` (named surfaces, paired by ``geometry.pairing``) or
                :class:`AveragedContact` (named surfaces, points averaging patches of them)
    parameters: JSON-serialisable parameters that built the mesh (plus derived values
                under "derived", e.g. CAD volumes and the damper's nominal mass)
    hexahedra:  (n_hex, 8) int64 corner node indices, wedges: (n_wedge, 6): the other
                element shapes of an imported mesh (corner order: ``geometry.cells``)
    curved_edges: (c, 2) int64 sorted corner pairs (a < b) of the element edges that are
                curved, and edge_nodes: (c, 3) float64 their mid-edge node positions (m):
                quadratic geometry (an imported deck's mid nodes, a curved arc's). Every
                other edge is straight, its mid node halfway between its corners. The
                finite elements map each element isoparametrically through these
                (``fe.fem``), at either field order.
    supports:   name -> :class:`Support`: the nodes the file holds (an imported deck's
                ``*BOUNDARY``), each within one body
    averages:   (a, 2) int64 rows (point, node), and average_weights: (a,) float64: points
                that belong to no element and move as a weighted average of nodes of one
                body, u(point) = sum of w u(node) over its rows (weights > 0, summing to 1;
                the point sits at the weighted mean of its nodes). A contact point standing
                for a patch of a finer surface mesh is one (its force goes back to the
                nodes with the same weights): the contact grid apart from the mesh.
    """

    model: str
    points: np.ndarray
    tetrahedra: np.ndarray
    bodies: dict[str, np.ndarray]
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    cyclic: dict[str, CyclicBoundary] = field(default_factory=dict)
    contacts: dict[str, ContactPatch | SurfaceContact | AveragedContact] = field(
        default_factory=dict)
    parameters: dict = field(default_factory=dict)
    hexahedra: np.ndarray = field(default_factory=lambda: elements.empty("hexahedron"))
    wedges: np.ndarray = field(default_factory=lambda: elements.empty("wedge"))
    curved_edges: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    edge_nodes: np.ndarray = field(default_factory=lambda: np.empty((0, 3)))
    supports: dict[str, Support] = field(default_factory=dict)
    averages: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    average_weights: np.ndarray = field(default_factory=lambda: np.empty(0))

    # ------------------------------------------------------------------ checks
    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise MeshValidationError(f"points: expected shape (n, 3), got {points.shape}")
        if not np.all(np.isfinite(points)):
            raise MeshValidationError("points: non-finite coordinates")
        points = frozen(points)
        object.__setattr__(self, "points", points)
        for name, shape in _FIELDS.items():
            arr = index_array(name, getattr(self, name), 2)
            corners = elements.SHAPES[shape]
            if arr.shape[1] != corners:
                raise MeshValidationError(
                    f"{name}: expected shape (m, {corners}), got {arr.shape}")
            if arr.size and (arr.min() < 0 or arr.max() >= len(points)):
                raise MeshValidationError(f"{name}: indices outside [0, {len(points)})")
            bad = elements.inverted(points, shape, arr)
            if bad.size:
                raise MeshValidationError(
                    f"{name}: {bad.size} elements inverted or not positively oriented "
                    f"(first: element {int(bad[0])})")
            object.__setattr__(self, name, arr)
        n = len(points)
        self._check_curved_edges(n)
        object.__setattr__(self, "bodies", self._checked_bodies(self.element_count))
        self._check_averages(n)
        object.__setattr__(self, "node_sets", self._checked_node_sets(n))
        self._check_cyclic()
        self._check_contacts()
        for name, support in self.supports.items():
            if support.nodes.size and support.nodes.max() >= n:
                raise MeshValidationError(f"supports[{name!r}]: indices outside [0, {n})")
        try:
            json.dumps(self.parameters, sort_keys=True)
        except TypeError as exc:
            raise MeshValidationError(f"parameters are not JSON-serialisable: {exc}") from exc

    def _check_curved_edges(self, n: int) -> None:
        pairs = index_array("curved_edges", self.curved_edges, 2).reshape(-1, 2)
        xyz = np.asarray(self.edge_nodes, dtype=np.float64).reshape(-1, 3)
        if len(xyz) != len(pairs):
            raise MeshValidationError(f"edge_nodes: {len(xyz)} positions for "
                                      f"{len(pairs)} curved edges")
        if pairs.size and (pairs.min() < 0 or pairs.max() >= n
                           or np.any(pairs[:, 0] >= pairs[:, 1])):
            raise MeshValidationError("curved_edges: expected sorted node pairs (a < b) "
                                      f"in [0, {n})")
        if len(np.unique(pairs, axis=0)) != len(pairs):
            raise MeshValidationError("curved_edges: an edge is listed twice")
        if not np.all(np.isfinite(xyz)):
            raise MeshValidationError("edge_nodes: non-finite coordinates")
        object.__setattr__(self, "curved_edges", pairs)
        object.__setattr__(self, "edge_nodes", frozen(xyz))

    def _check_averages(self, n: int) -> None:
        rows = index_array("averages", self.averages, 2).reshape(-1, 2)
        w = np.asarray(self.average_weights, dtype=np.float64).reshape(-1)
        if len(w) != len(rows):
            raise MeshValidationError(f"average_weights: {len(w)} weights for {len(rows)} "
                                      "rows of averages")
        object.__setattr__(self, "averages", rows)
        object.__setattr__(self, "average_weights", frozen(w))
        if not len(rows):
            return
        if rows.min() < 0 or rows.max() >= n:
            raise MeshValidationError(f"averages: indices outside [0, {n})")
        if not np.all(np.isfinite(w)) or w.min() <= 0.0:
            raise MeshValidationError("average_weights: every weight must be > 0")
        points, row = np.unique(rows[:, 0], return_inverse=True)
        element_nodes = self._nodes_of(np.arange(self.element_count))
        if np.isin(points, element_nodes).any() or np.isin(rows[:, 1], points).any():
            raise MeshValidationError("averages: an averaged point is a node of an element "
                                      "or of another average")
        total = np.bincount(row, w, len(points))
        if np.abs(total - 1.0).max() > 1e-9:
            raise MeshValidationError("average_weights: the weights of a point do not sum "
                                      "to 1")
        owner = np.full(n, -1)
        for i, body in enumerate(self.bodies):
            owner[self.body_nodes(body)] = i
        body = owner[rows[:, 1]]
        if body.min() < 0:
            raise MeshValidationError("averages: a node averaged is in no element")
        lo = np.full(len(points), len(self.bodies))
        np.minimum.at(lo, row, body)
        if np.any(lo[row] != body):
            raise MeshValidationError("averages: a point averages nodes of two bodies")
        mean = np.zeros((len(points), 3))
        np.add.at(mean, row, w[:, None] * self.points[rows[:, 1]])
        err = np.abs(mean - self.points[points]).max()
        if err > MATCH_TOL:
            raise MeshValidationError(f"averages: a point is {err:.3e} m off the weighted "
                                      "mean of its nodes")

    def _checked_bodies(self, n_elements: int) -> dict[str, np.ndarray]:
        if not self.bodies:
            raise MeshValidationError("bodies: at least one body is required")
        bodies = {k: index_array(f"bodies[{k!r}]", v, 1) for k, v in self.bodies.items()}
        owner = np.full(n_elements, -1)
        for i, (name, idx) in enumerate(bodies.items()):
            if idx.size and (idx.min() < 0 or idx.max() >= n_elements):
                raise MeshValidationError(
                    f"bodies[{name!r}]: element indices outside [0, {n_elements})")
            if np.any(owner[idx] >= 0):
                raise MeshValidationError(f"bodies[{name!r}]: elements assigned to two bodies")
            owner[idx] = i
        if np.any(owner < 0):
            raise MeshValidationError(
                f"bodies: {int((owner < 0).sum())} elements belong to no body")
        seen: set[int] = set()
        for name, idx in bodies.items():
            nodes = set(self._nodes_of(idx).tolist())
            if nodes & seen:
                raise MeshValidationError(f"bodies[{name!r}] shares nodes with another body")
            seen |= nodes
        return bodies

    def _checked_node_sets(self, n: int) -> dict[str, np.ndarray]:
        sets = {}
        for name, idx in self.node_sets.items():
            arr = index_array(f"node_sets[{name!r}]", idx, 1)
            if arr.size and (arr.min() < 0 or arr.max() >= n):
                raise MeshValidationError(f"node_sets[{name!r}]: indices outside [0, {n})")
            if arr.size > 1 and np.any(np.diff(arr) <= 0):
                raise MeshValidationError(f"node_sets[{name!r}]: not sorted unique")
            sets[name] = arr
        return sets

    def _check_cyclic(self) -> None:
        for body, cyc in self.cyclic.items():
            if body not in self.bodies:
                raise MeshValidationError(f"cyclic[{body!r}]: unknown body")
            owned = self.body_nodes(body)
            for side in ("left", "right"):
                if not np.all(np.isin(getattr(cyc, side), owned)):
                    raise MeshValidationError(f"cyclic[{body!r}].{side}: nodes outside the body")
            if not cyc.matching:  # (geometry.sector checked the faces' distance)
                continue
            image = self.points[cyc.left] @ rotation_z(cyc.angle).T
            err = np.abs(image - self.points[cyc.right]).max(initial=0.0)
            if err > MATCH_TOL:
                raise MeshValidationError(
                    f"cyclic[{body!r}]: right != R(phi) left, max error {err:.3e} m"
                )

    def _check_contacts(self) -> None:
        for name, patch in self.contacts.items():
            if isinstance(patch, SurfaceContact):
                self._check_surface_contact(name, patch)
                continue
            for body, nodes in ((patch.body_a, patch.nodes_a), (patch.body_b, patch.nodes_b)):
                if body is None and isinstance(patch, AveragedContact):  # the ground
                    continue
                if body not in self.bodies:
                    raise MeshValidationError(f"contacts[{name!r}]: unknown body {body!r}")
                if not np.all(np.isin(nodes, self.body_points(body))):
                    raise MeshValidationError(f"contacts[{name!r}]: nodes outside body {body!r}")
            if patch.b_sector_offset and patch.body_b not in self.cyclic:
                raise MeshValidationError(
                    f"contacts[{name!r}]: b_sector_offset needs a cyclic body_b"
                )
            if isinstance(patch, AveragedContact):  # its partners apart by the gaps
                faces = patch.faces[patch.faces >= 0]
                if not np.all(np.isin(faces, self.body_points(patch.body_a))):
                    raise MeshValidationError(f"contacts[{name!r}]: faces outside body "
                                              f"{patch.body_a!r}")
                continue
            err = np.abs(self.patch_points(name, "a") - self.patch_points(name, "b")).max()
            if err > MATCH_TOL:
                raise MeshValidationError(
                    f"contacts[{name!r}]: grids do not coincide, max error {err:.3e} m"
                )

    def _check_surface_contact(self, name: str, c: SurfaceContact) -> None:
        for body, nodes in ((c.body_a, c.set_a), (c.body_b, c.set_b)):
            if body is None:
                continue
            if body not in self.bodies:
                raise MeshValidationError(f"contacts[{name!r}]: unknown body {body!r}")
            if nodes not in self.node_sets:
                raise MeshValidationError(f"contacts[{name!r}]: no node set {nodes!r}")
        if c.b_sector_offset and c.body_b not in self.cyclic:
            raise MeshValidationError(
                f"contacts[{name!r}]: b_sector_offset needs a cyclic body_b")

    # ----------------------------------------------------------------- queries
    @property
    def cells(self) -> dict[str, np.ndarray]:
        """shape -> (m, corners) elements of that shape (every shape, in element order)."""
        return {shape: getattr(self, name) for name, shape in _FIELDS.items()}

    def element_summary(self) -> str:
        """"4210 tetrahedra", "800 hexahedra + 40 wedges": the element count per shape."""
        return " + ".join(f"{len(getattr(self, name))} {name}" for name in _FIELDS
                          if len(getattr(self, name))) or "no elements"

    def mid_edge_points(self, pairs: np.ndarray) -> np.ndarray:
        """(e, 3) positions (m) of the mid-edge nodes of edges ``pairs`` (e, 2) sorted node
        pairs: the curved ones' given nodes, the straight ones' midpoints."""
        return mid_edge_points(self.points, pairs, self.curved_edges, self.edge_nodes)

    @property
    def element_count(self) -> int:
        """Elements of every shape."""
        return sum(len(c) for c in self.cells.values())

    def element_cells(self, index: np.ndarray) -> dict[str, np.ndarray]:
        """shape -> (m_s, corners) the given elements (global indices) of that shape, for
        the shapes among them."""
        index = np.asarray(index, dtype=np.int64)
        out, start = {}, 0
        for shape, c in self.cells.items():
            inside = (index >= start) & (index < start + len(c))
            if inside.any():
                out[shape] = c[index[inside] - start]
            start += len(c)
        return out

    def body_cells(self, body: str) -> dict[str, np.ndarray]:
        """shape -> (m_s, corners) elements of ``body`` (the shapes it has)."""
        return self.element_cells(self.bodies[body])

    def _nodes_of(self, index: np.ndarray) -> np.ndarray:
        parts = [c.ravel() for c in self.element_cells(index).values()]
        return np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.int64)

    def body_nodes(self, body: str) -> np.ndarray:
        """(k,) sorted unique int64 node indices used by the elements of ``body``."""
        return self._nodes_of(self.bodies[body])

    def body_points(self, body: str) -> np.ndarray:
        """(k,) sorted unique int64: ``body``'s nodes and the averaged points that move
        with them (``averages``)."""
        nodes = self.body_nodes(body)
        mine = self.averages[np.isin(self.averages[:, 1], nodes), 0]
        return np.union1d(nodes, mine)

    def averaging(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, nodes, weights) of the averaged ``points`` (k,) among ``averages``:
        row i of a (k, n) matrix holds the weights of points[i] (no rows for a point that
        is not averaged)."""
        points = np.asarray(points, dtype=np.int64).ravel()
        order = np.argsort(points)
        pos = np.searchsorted(points, self.averages[:, 0], sorter=order)
        pos = np.minimum(pos, max(len(points) - 1, 0))
        hit = (points[order[pos]] == self.averages[:, 0]) if len(points) else pos < 0
        return order[pos[hit]], self.averages[hit, 1], self.average_weights[hit]

    @property
    def averaged_points(self) -> np.ndarray:
        """(p,) sorted point indices that are averages of nodes (``averages``)."""
        return np.unique(self.averages[:, 0])

    def sector_angle(self, body: str) -> float:
        """phi = 2 pi / Ns of a cyclic body (rad)."""
        return self.cyclic[body].angle

    def patch_points(self, name: str, side: str) -> np.ndarray:
        """(n1, n2, 3) assembled coordinates (m) of side "a" or "b" of a contact patch.

        Side "b" is rotated by ``b_sector_offset * phi`` when the touching face belongs
        to a neighbouring sector (see :class:`ContactPatch`).
        """
        patch = self.contacts[name]
        if side == "a":
            return self.points[patch.nodes_a]
        if side != "b":
            raise ValueError(f"side must be 'a' or 'b', got {side!r}")
        xyz = self.points[patch.nodes_b]
        if patch.b_sector_offset:
            angle = patch.b_sector_offset * self.cyclic[patch.body_b].angle
            xyz = xyz @ rotation_z(angle).T
        return xyz

    def surface(self, body: str) -> np.ndarray:
        """(t, 3) int64 outer surface triangles of ``body`` (global node indices, normals
        out of the body; a quad face as two triangles); a sector body's cyclic faces are
        part of it."""
        return elements.triangulated(*elements.boundary_faces(self.body_cells(body)))

    def body_volume(self, body: str) -> float:
        """Sum of the element volumes of ``body`` (m^3)."""
        return float(sum(elements.volumes(self.points, shape, c).sum()
                         for shape, c in self.body_cells(body).items()))

    @cached_property
    def derived(self) -> dict:
        """What is computed from the mesh alone and asked for by several stages (the
        contacts' pairings, ``geometry.pairing.paired_contact``): kept with the mesh, which
        never changes, so each is computed once."""
        return {}

    @cached_property
    def content_hash(self) -> str:
        """sha256 hex digest over arrays, names and parameters (stable across runs)."""
        h = hashlib.sha256()

        def put(tag: str, arr: np.ndarray | None = None) -> None:
            h.update(tag.encode() + b"\0")
            if arr is not None:
                a = np.ascontiguousarray(arr)
                h.update(str(a.shape).encode() + a.dtype.str.encode() + a.tobytes())

        put(self.model)
        put("points", self.points)
        put("tetrahedra", self.tetrahedra)
        for name in ("hexahedra", "wedges"):  # (absent from tetrahedral meshes' digests)
            if len(getattr(self, name)):
                put(name, getattr(self, name))
        if len(self.curved_edges):  # (absent from straight meshes' digests)
            put("curved_edges", self.curved_edges)
            put("edge_nodes", self.edge_nodes)
        for name in sorted(self.bodies):
            put("body/" + name, self.bodies[name])
        for name in sorted(self.node_sets):
            put("set/" + name, self.node_sets[name])
        for name in sorted(self.cyclic):
            cyc = self.cyclic[name]
            if cyc.matching:
                put(f"cyclic/{name}/{cyc.sectors}", np.stack([cyc.left, cyc.right]))
            else:
                put(f"cyclic/{name}/{cyc.sectors}/interpolated", cyc.left)
                put("right", cyc.right)
        for name in sorted(self.contacts):
            p = self.contacts[name]
            if isinstance(p, SurfaceContact):
                put(f"surface-contact/{name}/{p.body_a}/{p.set_a}/{p.body_b}/{p.set_b}/"
                    f"{p.b_sector_offset}/{p.tolerance!r}/{p.spread}")
                continue
            if isinstance(p, AveragedContact):
                put(f"averaged-contact/{name}/{p.body_a}/{p.body_b}/{p.b_sector_offset}/"
                    f"{p.spread}/{p.spacing!r}")
                for part in (p.nodes_a, p.nodes_b, p.normals, p.areas, p.gaps, p.faces,
                             p.owner):
                    put("", part)
                continue
            put(f"contact/{name}/{p.body_a}/{p.body_b}/{p.b_sector_offset}/{p.area!r}")
            put("a", p.nodes_a)
            put("b", p.nodes_b)
            put("n", p.normal)
        for name in sorted(self.supports):
            put(f"support/{name}/{self.supports[name].digest}")
        if len(self.averages):  # (absent from the digests of meshes without)
            put("averages", self.averages)
            put("average_weights", self.average_weights)
        put(json.dumps(self.parameters, sort_keys=True))
        return h.hexdigest()

    # ---------------------------------------------------------------------- IO
    def to_meshio(self):
        """meshio.Mesh: one cell block per body and shape, cell data "body" (int), and per node
        set a 0/1 point-data mask named like the set ("/" replaced by "."), for ParaView."""
        import meshio

        names = list(self.bodies)
        blocks = [(i, shape, c) for i, b in enumerate(names)
                  for shape, c in self.body_cells(b).items()]
        cells = [(shape, _vtk_order(shape, c)) for _, shape, c in blocks]
        body_id = [np.full(len(c), i, dtype=np.int32) for i, _, c in blocks]
        point_data = {}
        for name, idx in self.node_sets.items():
            mask = np.zeros(len(self.points), dtype=np.uint8)
            mask[idx] = 1
            point_data[name.replace("/", ".")] = mask
        return meshio.Mesh(
            np.asarray(self.points),
            cells,
            point_data=point_data,
            cell_data={"body": body_id},
            field_data={b: np.array([i, 3]) for i, b in enumerate(names)},
        )

    def write_msh(self, path) -> Path:
        """Write a Gmsh 2.2 ASCII file: one physical volume per body, one physical point
        group (vertex cells) per node set; physical names are the body and set names."""
        import meshio

        path = Path(path)
        cells, phys, geom, field_data = [], [], [], {}
        tag = 1
        for name in self.bodies:
            for shape, c in self.body_cells(name).items():
                cells.append((shape, c))
                phys.append(np.full(len(c), tag, dtype=np.int32))
            field_data[name] = np.array([tag, 3])
            tag += 1
        for name, idx in self.node_sets.items():
            cells.append(("vertex", idx.reshape(-1, 1)))
            phys.append(np.full(len(idx), tag, dtype=np.int32))
            field_data[name] = np.array([tag, 0])
            tag += 1
        geom = [p.copy() for p in phys]
        m = meshio.Mesh(
            np.asarray(self.points),
            cells,
            cell_data={"gmsh:physical": phys, "gmsh:geometrical": geom},
            field_data=field_data,
        )
        meshio.write(path, m, file_format="gmsh22", binary=False)
        return path

    def write(self, path) -> Path:
        """Write by suffix: ".msh" (Gmsh) or anything meshio knows (".vtu", ".xdmf", ...)."""
        import meshio

        path = Path(path)
        if path.suffix == ".msh":
            return self.write_msh(path)
        meshio.write(path, self.to_meshio())
        return path


def mid_edge_points(points: np.ndarray, pairs: np.ndarray, curved_edges: np.ndarray,
                    edge_nodes: np.ndarray) -> np.ndarray:
    """(e, 3) mid-edge node positions (m) of the edges ``pairs`` (e, 2) sorted node pairs:
    ``edge_nodes[i]`` for ``curved_edges[i]``, the straight midpoint for the others."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    out = 0.5 * (points[pairs[:, 0]] + points[pairs[:, 1]])
    if len(curved_edges) and len(pairs):
        n = max(int(pairs.max()), int(curved_edges.max())) + 1
        key = pairs[:, 0] * n + pairs[:, 1]
        curved = curved_edges[:, 0] * n + curved_edges[:, 1]
        order = np.argsort(curved)
        at = np.minimum(np.searchsorted(curved, key, sorter=order), len(curved) - 1)
        hit = curved[order[at]] == key
        out[hit] = edge_nodes[order[at[hit]]]
    return out


def _vtk_order(shape: str, corners: np.ndarray) -> np.ndarray:
    """Corners in VTK's order: its wedge has the bottom triangle's normal pointing away from
    the top one (ours, Abaqus' and Gmsh's point to it)."""
    return corners[:, elements.MIRROR["wedge"]] if shape == "wedge" else corners


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """(m,) signed volumes (m^3) of tets (m, 4) over points (n, 3); > 0 when positive."""
    return elements.volumes(points, "tetra", tets)


def boundary_triangles(tets: np.ndarray) -> np.ndarray:
    """(t, 3) faces of positively oriented tets (m, 4) that belong to one tet only: the
    outer surface, each triangle ordered so that its normal points out of the solid."""
    return elements.boundary_faces({"tetra": tets})[0]
