"""Meshes from other tools: a mesh file read into a :class:`Mesh` (SI units, corner nodes).

Formats, by suffix: CalculiX/Abaqus ``.inp`` (``geometry.abaqus``: meshio loses sets that
span element types), Nastran ``.bdf`` / ``.nas`` / ``.dat``, Gmsh ``.msh`` and everything
else meshio reads (``.vtu``, ``.med``, ``.exo``, ...) through meshio. Solid elements: 4- and
10-node tetrahedra, 8-, 20- and 27-node hexahedra, 6- and 15-node wedges. A mesh keeps their
corners as nodes and the quadratic ones' mid-edge nodes as the geometry of their edges
(``Mesh.curved_edges``, where a node lies off its straight edge's midpoint): the finite
elements map each element through them, curved as the file says, at either field order;
the quadratic elements' edge DOFs (``[reduction] order = 2``) are these nodes. A 27-node
hexahedron's face and centre nodes are not kept (its geometry is the 20-node one's).
:attr:`ImportReport.midnode_offset` says how far the file's mid nodes were from straight.

Names the file gives carry over:

* bodies: the groups of solid elements (Gmsh physical volumes, Abaqus element sets, Nastran
  property ids as ``pid<N>``) that are disjoint and together hold every solid element; or
  the groups the case names (``bodies = [...]``); or, without groups, one body ``"body"``.
  Bodies share no node (touching bodies carry distinct, coincident nodes);
* node sets: the file's node sets (Abaqus ``*NSET``), the nodes of every group of elements
  (Gmsh physical points, curves and surfaces; element sets), under their own names.

Element orientation: each shape's corners are taken in the orientation most of the file's
elements of that shape have (readers differ, VTK mirrors the wedge); an element against it,
or tangled, is an inverted element and an error.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import cad, elements
from .body_groups import bodies_of
from .boundaries import FRAMES, MeshValidationError, Support
from .mesh import CURVED, Mesh
from .mesh_files import MeshImportError, read
from .sector import SectorError, SectorSpec, centring, cyclic_boundaries, sector_frame

#: meshio cell type -> our shape, of the solid elements read
SOLID_TYPES = elements.SOLID_TYPES
#: meshio cell types that are not solids: their nodes form node sets, nothing else
_FACE_TYPES = ("vertex", "line", "line3", "triangle", "triangle6", "quad", "quad8", "quad9")


@dataclass(frozen=True)
class Units:
    """A unit system by the SI value of its length, mass and time units."""

    name: str
    length: float  # m
    mass: float  # kg
    time: float = 1.0  # s

    @property
    def force(self) -> float:
        """N per force unit."""
        return self.mass * self.length / self.time**2

    @property
    def stress(self) -> float:
        """Pa per stress unit."""
        return self.force / self.length**2

    @property
    def density(self) -> float:
        """kg/m^3 per density unit."""
        return self.mass / self.length**3


_INCH, _LBF = 0.0254, 4.4482216152605
#: The unit systems a file may be written in (``[geometry] units``).
UNITS = {u.name: u for u in (
    Units("SI", 1.0, 1.0),
    Units("mm-t-s", 1e-3, 1e3),  # N, MPa, t/mm^3
    Units("mm-kg-s", 1e-3, 1.0),  # mN, kPa, kg/mm^3
    Units("in-lbf-s", _INCH, _LBF / _INCH),  # lbf, psi, lbf s^2/in^4 (slinch/in^3)
)}


@dataclass(frozen=True)
class Selection:
    """A node set chosen by geometry: the nodes of the bodies' outer surfaces (of ``body``
    only, if given) within ``tolerance`` [m] of a region of the file's frame, in metres:

    box: ((x0, y0, z0), (x1, y1, z1)) corners; plane: (point, normal); radius: the cylinder
    of that radius about the sector's axis (needs a sector).
    """

    box: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    plane: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    radius: float | None = None
    tolerance: float = 1e-6
    body: str | None = None

    def nodes(self, mesh: Mesh, sector: SectorSpec | None) -> np.ndarray:
        """Sorted indices of the selected nodes of ``mesh`` (in the file's frame, SI)."""
        bodies = [self.body] if self.body else list(mesh.bodies)
        surface = np.unique(np.concatenate([mesh.surface(b).ravel() for b in bodies]))
        x = mesh.points[surface]
        inside = np.ones(len(x), dtype=bool)
        if self.box is not None:
            lo, hi = np.minimum(*self.box), np.maximum(*self.box)
            inside &= ((x >= lo - self.tolerance) & (x <= hi + self.tolerance)).all(axis=1)
        if self.plane is not None:
            normal = np.asarray(self.plane[1]) / np.linalg.norm(self.plane[1])
            inside &= np.abs((x - np.asarray(self.plane[0])) @ normal) <= self.tolerance
        if self.radius is not None:
            axis = np.asarray(sector.axis) / np.linalg.norm(sector.axis)
            d = x - np.asarray(sector.origin)
            r = np.linalg.norm(d - np.outer(d @ axis, axis), axis=1)
            inside &= np.abs(r - self.radius) <= self.tolerance
        return surface[inside]


@dataclass(frozen=True)
class ImportReport:
    """What reading the file found besides the mesh (for the run's log and the checks).

    elements: meshio cell type -> count of the solid elements read; midnode_offset: the
    largest distance of a quadratic element's mid node from its straight edge's midpoint,
    relative to that edge's length (0 for a linear mesh); dropped_sets: the file's node sets
    left empty by dropping mid nodes (they held nothing else); curved_edges: how many edges
    the mesh keeps curved; skipped: element type -> count
    of the elements that are not solids (surface, shell, beam elements of a deck: their
    nodes are node sets, they are not part of the model).
    """

    elements: dict[str, int]
    midnode_offset: float = 0.0
    dropped_sets: tuple[str, ...] = ()
    skipped: dict[str, int] = field(default_factory=dict)
    curved_edges: int = 0


@dataclass(frozen=True)
class ImportedMesh:
    """The mesh and what reading it found."""

    mesh: Mesh
    report: ImportReport = field(default_factory=lambda: ImportReport({}))


def import_mesh(path: str | Path, units: str = "SI", bodies: dict[str, str] | None = None,
                sector: SectorSpec | None = None, sets: dict[str, Selection] | None = None,
                size: float | None = None, model: str = "import") -> ImportedMesh:
    """Read a mesh file into a :class:`Mesh` in SI units (see the module).

    units: the file's unit system (a key of :data:`UNITS`); bodies: body name -> the element
    group that is that body (None: found as the module says); sector: how the mesh is a
    sector of a cyclic structure (``geometry.sector``); sets: node sets chosen by geometry
    (:class:`Selection`), beside the file's. With a sector, the mesh is moved into the
    contract's frame (axis +z, sector around +x) and its cyclic faces paired;
    ``parameters["frame"]`` records the motion: x = rotation (x_file [m] - origin).
    """
    _check_units(path, units)
    raw = read(path, UNITS[units].length, size, sector)
    if sector is not None and Path(path).suffix.lower() in cad.SUFFIXES:
        sector = _with_meshed_faces(raw, bodies, sector)
    solids, points = _solid_blocks(raw, path)
    groups = _element_groups(raw)
    corners, mids = _corners(points, raw, solids, path)
    body_of = bodies_of(groups, solids, raw, bodies, path)
    kept = _CornerNumbering.of(points, solids, corners, body_of)
    node_sets, dropped = _node_sets(raw, groups, kept.used, kept.new)
    length = (getattr(raw, "info", None) or {}).get("length", UNITS[units].length)  # (CAD)
    curved, mid_xyz, offset = _curved_edges(points, mids, kept.new)
    parts = _MeshParts(
        model, kept.cells, kept.body_index, node_sets, curved, mid_xyz * length,
        _deck_supports(raw, kept.used, kept.new, length),
        {"file": Path(path).name, "units": units, "dropped_sets": list(dropped),
         "materials": _body_materials(raw, solids, body_of, UNITS[units], kept.first)},
        str(path))
    mesh = parts.mesh(points[kept.used] * length)
    if sets:  # chosen on the mesh in the file's frame
        parts = replace(parts, node_sets=node_sets | _selected(sets, node_sets, mesh, sector))
    if sector is not None:
        mesh = _in_sector_frame(parts, mesh, sector)
    elif sets:
        mesh = parts.mesh(mesh.points)
    count = {b.type: 0 for _, b in solids}
    for _, b in solids:
        count[b.type] += len(b.data)
    skipped = dict((getattr(raw, "info", None) or {}).get("skipped", {}))
    return ImportedMesh(mesh, ImportReport(count, offset, dropped, skipped, len(curved)))


def _check_units(path: str | Path, units: str) -> None:
    """MeshImportError unless ``units`` names a unit system the file may be given in."""
    if units not in UNITS:
        raise MeshImportError(f"units = {units!r}: expected one of {sorted(UNITS)}")
    suffix = Path(path).suffix.lower()
    if suffix in cad.SUFFIXES and units != "SI" and suffix != ".brep":
        raise MeshImportError(f"units = {units!r}: {Path(path).name} declares its own unit "
                              "(STEP and IGES are converted to metres); leave units out")


def _with_meshed_faces(raw, bodies: dict[str, str] | None, sector: SectorSpec) -> SectorSpec:
    """The sector with the cyclic faces Gmsh meshed as each other's images (a CAD file's
    ``cyclic/<group>/left|right`` point sets) of every body whose faces it does not name."""
    group_of = dict(bodies or {}) or {g: g for g in (raw.cell_sets or {})}
    given = {b for b, _, _ in sector.faces}
    found = tuple((b, f"cyclic/{g}/left", f"cyclic/{g}/right")
                  for b, g in group_of.items() if b not in given
                  and f"cyclic/{g}/left" in (raw.point_sets or {}))
    return replace(sector, faces=sector.faces + found)


def _solid_blocks(raw, path) -> tuple[list, np.ndarray]:
    """The (index, cell block) of the solid element blocks and the (n, 3) nodes, checked:
    MeshImportError for an element type neither solid nor face, no solid, bad coordinates."""
    solids = [(i, b) for i, b in enumerate(raw.cells) if b.type in SOLID_TYPES]
    unknown = sorted({b.type for b in raw.cells} - set(SOLID_TYPES) - set(_FACE_TYPES))
    if unknown:
        raise MeshImportError(
            f"{path}: element type(s) {unknown} not supported; solids read: "
            f"{sorted(set(SOLID_TYPES))}")
    if not solids:
        raise MeshImportError(f"{path}: no solid elements (tetrahedra, hexahedra, wedges)")
    points = np.asarray(raw.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise MeshImportError(f"{path}: node coordinates must be finite 3D points")
    return solids, points


@dataclass(frozen=True)
class _CornerNumbering:
    """The corner nodes kept, in file order, and the elements numbered by shape, then in
    file order. used: (n,) the file's nodes kept; new: (n,) their index among those kept;
    first: solid block position -> its first element index; cells: shape -> (m, corners)
    kept node indices; body_index: body -> its sorted element indices."""

    used: np.ndarray
    new: np.ndarray
    first: dict[int, int]
    cells: dict[str, np.ndarray]
    body_index: dict[str, np.ndarray]

    @classmethod
    def of(cls, points: np.ndarray, solids, corners: dict[int, np.ndarray],
           body_of: dict[str, dict[int, np.ndarray]]) -> _CornerNumbering:
        shapes = list(elements.SHAPES)
        used = np.zeros(len(points), dtype=bool)
        for c in corners.values():
            used[c.ravel()] = True
        new = np.cumsum(used) - 1
        order = {s: [k for k, (i, b) in enumerate(solids) if SOLID_TYPES[b.type] == s]
                 for s in shapes}
        start, first = 0, {}
        for s in shapes:
            for k in order[s]:
                first[k] = start
                start += len(solids[k][1].data)
        body_index = {name: np.sort(np.concatenate([first[k] + idx
                                                    for k, idx in parts.items()]))
                      for name, parts in body_of.items()}
        cells = {s: (np.concatenate([new[corners[k]] for k in order[s]]) if order[s]
                     else elements.empty(s)) for s in shapes}
        return cls(used, new, first, cells, body_index)


@dataclass(frozen=True)
class _MeshParts:
    """Everything of the Mesh but its nodes and cyclic faces; the mid nodes (``edge_nodes``
    [m]) and supports move with the nodes (:meth:`moved`)."""

    model: str
    cells: dict[str, np.ndarray]
    bodies: dict[str, np.ndarray]
    node_sets: dict[str, np.ndarray]
    curved_edges: np.ndarray
    edge_nodes: np.ndarray
    supports: dict[str, Support]
    parameters: dict
    path: str

    def mesh(self, xyz: np.ndarray, cyclic: dict | None = None) -> Mesh:
        """The mesh on nodes ``xyz`` [m] (the parts in their frame)."""
        try:
            return Mesh(model=self.model, points=xyz, tetrahedra=self.cells["tetra"],
                        hexahedra=self.cells["hexahedron"], wedges=self.cells["wedge"],
                        bodies=self.bodies, node_sets=self.node_sets, cyclic=cyclic or {},
                        parameters=self.parameters, curved_edges=self.curved_edges,
                        edge_nodes=self.edge_nodes, supports=self.supports)
        except MeshValidationError as exc:
            raise MeshImportError(f"{self.path}: {exc}") from None

    def moved(self, motion: np.ndarray) -> _MeshParts:
        """The parts after the affine map x -> [x, 1] @ motion, ``motion`` (4, 3)."""
        return replace(self, edge_nodes=self.edge_nodes @ motion[:3] + motion[3],
                       supports={n: s.moved(motion[:3].T, motion[3])
                                 for n, s in self.supports.items()})


def _selected(sets: dict[str, Selection], held: dict[str, np.ndarray], mesh: Mesh,
              sector: SectorSpec | None) -> dict[str, np.ndarray]:
    """The node sets chosen by geometry on ``mesh`` (in the file's frame), checked against
    the file's sets ``held`` and the mesh's bodies."""
    chosen = {}
    for name, selection in sets.items():
        if name in held:
            raise MeshImportError(f"geometry.sets.{name}: the file has a set of that name")
        if selection.body is not None and selection.body not in mesh.bodies:
            raise MeshImportError(f"geometry.sets.{name}.body = {selection.body!r}: not a "
                                  f"body; bodies: {sorted(mesh.bodies)}")
        if selection.radius is not None and sector is None:
            raise MeshImportError(f"geometry.sets.{name}.radius: needs [geometry.sector] "
                                  "(the axis it is measured from)")
        chosen[name] = selection.nodes(mesh, sector)
        if not chosen[name].size:
            raise MeshImportError(f"geometry.sets.{name}: selects no surface node (widen "
                                  "the region or its tolerance)")
    return chosen


def _in_sector_frame(parts: _MeshParts, mesh: Mesh, sector: SectorSpec) -> Mesh:
    """The mesh moved into the contract's frame (axis +z, sector around +x) with its cyclic
    faces paired; its ``parameters["frame"]``: the motion from the file's frame."""
    rotation, origin = sector_frame(sector.axis, sector.origin)
    to_axis = np.vstack([rotation.T, -origin @ rotation.T])
    parts = parts.moved(to_axis)
    mesh = parts.mesh((mesh.points - origin) @ rotation.T)
    try:
        xyz, boundaries = cyclic_boundaries(mesh, sector)
    except SectorError as exc:
        raise MeshImportError(str(exc)) from None
    if not boundaries:
        raise MeshImportError(
            f"geometry.sector: no body of {parts.path} has two faces on planes through the "
            f"axis {list(sector.axis)} 2 pi / {sector.sectors} apart; name them in "
            "[geometry.sector.faces]")
    centre = centring(xyz, boundaries, sector.angle)
    frame = {"rotation": (centre @ rotation).tolist(), "origin": origin.tolist(),
             "sectors": sector.sectors}
    parts = replace(parts, parameters=parts.parameters | {"frame": frame})
    return parts.moved(np.vstack([centre.T, np.zeros(3)])).mesh(xyz @ centre.T, boundaries)


def _body_materials(raw, solids, body_of, units: Units, first: dict[int, int]
                    ) -> dict[str, dict | str]:
    """Body -> its material from the file's cards in SI (youngs_modulus [Pa], poisson_ratio,
    density [kg/m^3], name), or for a body of several materials ``{"zones": [that and
    "elements": its mesh element indices, ...]}``, or why the file gives none (``material =
    "file"`` reads these). ``first``: each solid block's first element index in the mesh."""
    info = getattr(raw, "info", None) or {}
    per_block, table = info.get("element_materials"), info.get("materials", {})
    out: dict[str, dict | str] = {}
    for body, parts in body_of.items():
        if per_block is None or isinstance(table, str):
            out[body] = table if isinstance(table, str) else "the format carries no materials"
            continue
        members: dict = {}  # material key -> its elements (mesh indices)
        for k, idx in parts.items():
            keys = np.array([_key_of(v) for v in np.asarray(per_block[solids[k][0]])[idx]],
                            dtype=object)
            for key in set(keys.tolist()):
                members.setdefault(key, []).append(first[k] + idx[keys == key])
        if "" in members:
            out[body] = (f"{len(np.concatenate(members['']))} of its elements have no "
                         "material" if len(members) > 1 else "its elements have no material")
            continue
        cards = {key: _card(key, table, units) for key in sorted(members, key=str)}
        fault = next((c for c in cards.values() if isinstance(c, str)), None)
        if fault is not None or len(cards) == 1:
            out[body] = fault or next(iter(cards.values()))
        else:
            out[body] = {"zones": [card | {"elements": np.sort(np.concatenate(
                members[key])).tolist()} for key, card in cards.items()]}
    return out


def _card(key, table: dict, units: Units) -> dict | str:
    """Material ``key`` of the file's cards in SI, or why it cannot be used."""
    found = table.get(key, (np.nan,) * 3)
    if isinstance(found, str):
        return f"material {key!r}: {found}"
    E, nu, rho = found
    missing = [n for n, v in (("E", E), ("nu", nu), ("density", rho)) if not np.isfinite(v)]
    if missing:
        return f"material {key!r} lacks {', '.join(missing)}"
    return {"youngs_modulus": E * units.stress, "poisson_ratio": nu,
            "density": rho * units.density, "name": str(key)}


def _key_of(value) -> str | int:
    """A material key as the tables hold it (ids as int, names as str)."""
    if isinstance(value, str):
        return value
    return int(value)


def _element_groups(raw) -> dict[str, dict[int, np.ndarray]]:
    """Group name -> cell block index -> element indices in that block: the file's element
    sets, Gmsh physical groups and Nastran property ids."""
    groups: dict[str, dict[int, np.ndarray]] = {}
    for name, per_block in (raw.cell_sets or {}).items():
        if name.startswith("gmsh:"):  # meshio's bookkeeping of Gmsh entities, not a group
            continue
        for i, idx in enumerate(per_block):
            if idx is not None and len(idx):
                groups.setdefault(name, {})[i] = np.asarray(idx, dtype=np.int64)
    names = {(int(tag), int(dim)): name for name, (tag, dim) in (raw.field_data or {}).items()}
    for key, prefix in (("gmsh:physical", None), ("nastran:ref", "pid")):
        for i, tags in enumerate(raw.cell_data.get(key, [])):
            if tags is None:
                continue
            dim = _DIM.get(raw.cells[i].type, 3)
            tags = np.asarray(tags).astype(np.int64).ravel()
            for tag in np.unique(tags):
                name = (f"{prefix}{tag}" if prefix else names.get((int(tag), dim)))
                if name is not None:
                    groups.setdefault(name, {})[i] = np.flatnonzero(tags == tag)
    return groups


_DIM = {"vertex": 0, "line": 1, "line3": 1, "triangle": 2, "triangle6": 2, "quad": 2,
        "quad8": 2, "quad9": 2}


def _corners(points: np.ndarray, raw, solids, path
             ) -> tuple[dict[int, np.ndarray], list[np.ndarray]]:
    """Block index -> (m, corners) positively oriented corner nodes; and per quadratic
    block (k, 3) rows (corner a, corner b, mid node) of file node indices."""
    out, mids = {}, []
    for k, (_, block) in enumerate(solids):
        shape = SOLID_TYPES[block.type]
        data = np.asarray(block.data, dtype=np.int64)
        c = data[:, : elements.SHAPES[shape]]
        if data.shape[1] > c.shape[1]:
            mids.append(_edge_mid_nodes(points, shape, c, data[:, c.shape[1]:], block.type,
                                        path))
        jac = elements.corner_jacobians(points, shape, c)
        positive = (jac > 0).all(axis=1)
        negative = (jac < 0).all(axis=1)
        if negative.sum() > positive.sum():  # this reader's convention mirrors ours
            c, positive = c[:, elements.MIRROR[shape]], negative
        bad = np.flatnonzero(~positive)
        if bad.size:
            raise MeshImportError(
                f"{path}: {bad.size} {block.type} element(s) inverted or tangled (first: "
                f"element {int(bad[0]) + 1} of that type in the file)")
        out[k] = c
    return out, mids


def _deck_supports(raw, used: np.ndarray, new: np.ndarray, length: float
                   ) -> dict[str, Support]:
    """The deck's supports (``*BOUNDARY``, in the frames of ``*TRANSFORM``) on the corner
    nodes kept, one Support per frame and held directions: "boundary/<frame>/<held>"."""
    info = getattr(raw, "info", None) or {}
    held = np.zeros((len(raw.points), 3), dtype=bool)
    for nodes, dofs, _ in info.get("boundary", []):
        for d in dofs:
            held[np.asarray(nodes, dtype=np.int64), d - 1] = True
    frame_of = np.full(len(raw.points), -1)
    frames = []
    for name, (kind, a, b, nodes) in info.get("transforms", {}).items():
        frames.append((name, *_transform(kind, np.asarray(a, float), np.asarray(b, float))))
        frame_of[np.asarray(nodes, dtype=np.int64)] = len(frames) - 1
    out = {}
    rows = np.flatnonzero(held.any(axis=1) & used)
    groups = frame_of[rows] * 8 + held[rows] @ np.array([1, 2, 4])
    for g in np.unique(groups):
        nodes = rows[groups == g]
        mask = held[nodes[0]]
        f = int(frame_of[nodes[0]])
        if f < 0:
            name, frame, axes, origin = "global", "global", np.eye(3), np.zeros(3)
        else:
            name, frame, axes, origin = frames[f]
        letters = "".join(c for c, h in zip(FRAMES[frame], mask, strict=True) if h)
        out[f"boundary/{name}/{letters}"] = Support(new[nodes], mask, frame, axes,
                                                    origin * length)
    return out


def _transform(kind: str, a: np.ndarray, b: np.ndarray) -> tuple[str, np.ndarray, np.ndarray]:
    """(frame, axes (3, 3) rows, origin) of a ``*TRANSFORM``: TYPE=R, local x along a, y in
    the plane of a and b; TYPE=C, the axis from point a to point b (local r, theta, z)."""
    if kind == "R":
        x = a / np.linalg.norm(a)
        y = b - (b @ x) * x
        y = y / np.linalg.norm(y)
        return "rectangular", np.array([x, y, np.cross(x, y)]), np.zeros(3)
    z = (b - a) / np.linalg.norm(b - a)
    e = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = e - (e @ z) * z
    x = x / np.linalg.norm(x)
    return "cylindrical", np.array([x, np.cross(z, x), z]), a


def _edge_mid_nodes(points, shape, corners, extra, kind, path) -> np.ndarray:
    """(m e, 3) rows (corner a, corner b, its mid node) of every edge of the elements: each
    edge takes the mid node nearest its straight midpoint (order-free: readers order mid
    nodes differently); MeshImportError if two edges of an element would take one node."""
    edges = np.asarray(elements.EDGES[shape])
    extra = extra[:, : len(edges)]  # a hexahedron27's face and centre nodes are not on edges
    a, b = corners[:, edges[:, 0]], corners[:, edges[:, 1]]  # (m, e)
    mid = 0.5 * (points[a] + points[b])
    d = np.linalg.norm(points[extra][:, None, :, :] - mid[:, :, None, :], axis=3)  # (m, e, x)
    pick = d.argmin(axis=2)
    clash = np.flatnonzero((np.sort(pick, axis=1)[:, 1:] == np.sort(pick, axis=1)[:, :-1])
                           .any(axis=1))
    if clash.size:
        raise MeshImportError(
            f"{path}: the mid-edge nodes of {kind} element {int(clash[0]) + 1} (of that type "
            "in the file) do not lie one near each edge (a distorted or mis-numbered element)")
    node = np.take_along_axis(extra, pick, axis=1)
    return np.stack([a.ravel(), b.ravel(), node.ravel()], axis=1)


def _curved_edges(points, mids, new) -> tuple[np.ndarray, np.ndarray, float]:
    """(c, 2) sorted corner pairs in the kept numbering and (c, 3) mid node positions (the
    file's units) of the edges whose mid node lies off the straight midpoint (by more than
    ``mesh.CURVED`` of the edge: closer, a straight edge's rounding), and the
    largest such offset relative to its edge's length (0 for a linear mesh)."""
    if not mids:
        return np.empty((0, 2), dtype=np.int64), np.empty((0, 3)), 0.0
    rows = np.concatenate(mids)
    pairs = np.sort(rows[:, :2], axis=1)
    pairs, first = np.unique(pairs, axis=0, return_index=True)  # one node per edge
    xyz = points[rows[first, 2]]
    a, b = points[pairs[:, 0]], points[pairs[:, 1]]
    relative = np.linalg.norm(xyz - 0.5 * (a + b), axis=1) / np.linalg.norm(b - a, axis=1)
    off = relative > CURVED
    return np.sort(new[pairs[off]], axis=1), xyz[off], float(relative.max(initial=0.0))


def _node_sets(raw, groups, used, new) -> tuple[dict[str, np.ndarray], tuple[str, ...]]:
    """The file's node sets and the nodes of its element groups, renumbered to the corner
    nodes kept; the names left empty by that (sets of mid nodes only)."""
    found: dict[str, np.ndarray] = {}
    for name, idx in (raw.point_sets or {}).items():
        found[name] = np.asarray(idx, dtype=np.int64).ravel()
    for name, g in groups.items():
        if name not in found:
            found[name] = np.unique(np.concatenate(
                [np.asarray(raw.cells[i].data)[idx].ravel() for i, idx in g.items()]))
    sets, dropped = {}, []
    for name, idx in sorted(found.items()):
        kept = np.unique(new[idx[used[idx]]])
        if kept.size:
            sets[name] = kept
        else:
            dropped.append(name)
    return sets, tuple(dropped)
