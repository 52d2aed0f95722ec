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

import contextlib
import io
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import abaqus, cad, deck_supports, elements, materials
from .boundaries import FRAMES, MeshValidationError, Support
from .mesh import CURVED, Mesh
from .params import GeometryBuildError
from .sector import SectorError, SectorSpec, centring, cyclic_boundaries, sector_frame

#: meshio cell type -> our shape, of the solid elements read
SOLID_TYPES = elements.SOLID_TYPES
#: meshio cell types that are not solids: their nodes form node sets, nothing else
_FACE_TYPES = ("vertex", "line", "line3", "triangle", "triangle6", "quad", "quad8", "quad9")
_NAME = re.compile(r"^[A-Za-z0-9_.\-]+(/[A-Za-z0-9_.\-]+)*$")


class MeshImportError(ValueError):
    """A mesh file cannot be read into a Mesh; the message is one line naming what and why."""


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


def read(path: str | Path, length: float = 1.0, size: float | None = None,
         sector: SectorSpec | None = None):
    """The file as a meshio.Mesh; MeshImportError (one line) if it is missing or unreadable.
    A CAD file is meshed (``geometry.cad``: ``length`` [m] per BREP unit, ``size`` [m])."""
    import meshio
    from meshio import _mesh

    # meshio 5.3.5 reads 15-node wedges (C3D15, CPENTA, Gmsh type 18) but its table of cell
    # dimensions lacks them, so building the cell block fails: the missing entry, added once
    _mesh.topological_dimension.setdefault("wedge15", 3)
    path = Path(path)
    if not path.is_file():
        raise MeshImportError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix in cad.SUFFIXES:
        try:
            return cad.mesh(path, length, size, sector)
        except GeometryBuildError as exc:
            raise MeshImportError(str(exc).splitlines()[0]) from None
    if suffix == ".inp":
        try:
            return abaqus.read(path)
        except abaqus.DeckError as exc:
            raise MeshImportError(str(exc)) from None
    if suffix == ".cdb":
        return _ansys_archive(path)
    fmt = {".bdf": "nastran", ".nas": "nastran", ".dat": "nastran", ".msh": "gmsh"}.get(suffix)
    said = io.StringIO()
    try:  # meshio prints its complaints and exits when no reader takes the file
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            raw = meshio.read(path, file_format=fmt)
            if fmt == "nastran":  # each element's property id names its material
                raw.info = {"element_materials": raw.cell_data.get("nastran:ref"),
                            "materials": _cards(materials.nastran, path),
                            "boundary": _held_nodes(deck_supports.nastran, path,
                                                    getattr(raw, "points_id", None))}
            return raw
    except deck_supports.SupportError as exc:
        raise MeshImportError(str(exc)) from None
    except (Exception, SystemExit) as exc:  # anything from KeyError to IndexError
        text = said.getvalue() if isinstance(exc, SystemExit) else str(exc) or said.getvalue()
        lines = [x for x in text.strip().splitlines() if x.strip()]
        why = lines[-1] if lines else type(exc).__name__
        raise MeshImportError(f"{path}: not a readable mesh ({why})") from None


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
    if units not in UNITS:
        raise MeshImportError(f"units = {units!r}: expected one of {sorted(UNITS)}")
    cad_file = Path(path).suffix.lower() in cad.SUFFIXES
    if cad_file and units != "SI" and Path(path).suffix.lower() != ".brep":
        raise MeshImportError(f"units = {units!r}: {Path(path).name} declares its own unit "
                              "(STEP and IGES are converted to metres); leave units out")
    raw = read(path, UNITS[units].length, size, sector)
    if cad_file and sector is not None:  # the faces Gmsh meshed as each other's images
        group_of = dict(bodies or {}) or {g: g for g in (raw.cell_sets or {})}
        given = {b for b, _, _ in sector.faces}
        found = tuple((b, f"cyclic/{g}/left", f"cyclic/{g}/right")
                      for b, g in group_of.items() if b not in given
                      and f"cyclic/{g}/left" in (raw.point_sets or {}))
        sector = replace(sector, faces=sector.faces + found)
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
    groups = _element_groups(raw)
    corners, mids = _corners(points, raw, solids, path)
    body_of = _bodies(groups, solids, raw, bodies, path)

    # keep the corner nodes only, in file order
    shapes = list(elements.SHAPES)
    used = np.zeros(len(points), dtype=bool)
    for c in corners.values():
        used[c.ravel()] = True
    new = np.cumsum(used) - 1
    # element numbering of the Mesh: by shape, then in file order
    order = {s: [k for k, (i, b) in enumerate(solids) if SOLID_TYPES[b.type] == s]
             for s in shapes}
    start, first = 0, {}
    for s in shapes:
        for k in order[s]:
            first[k] = start
            start += len(solids[k][1].data)
    body_index = {name: np.sort(np.concatenate([first[k] + idx for k, idx in parts.items()]))
                  for name, parts in body_of.items()}
    cells = {s: (np.concatenate([new[corners[k]] for k in order[s]]) if order[s]
                 else elements.empty(s)) for s in shapes}

    node_sets, dropped = _node_sets(raw, groups, used, new)
    length = (getattr(raw, "info", None) or {}).get("length", UNITS[units].length)  # (CAD)
    curved, mid_xyz, offset = _curved_edges(points, mids, new)
    mid_xyz = mid_xyz * length
    supports = _deck_supports(raw, used, new, length)
    parameters = {"file": Path(path).name, "units": units, "dropped_sets": list(dropped),
                  "materials": _body_materials(raw, solids, body_of, UNITS[units], first)}

    def mesh_of(xyz: np.ndarray, cyclic: dict | None = None,
                motion: np.ndarray | None = None) -> Mesh:
        """The mesh on nodes ``xyz``; ``motion`` (4, 3): the affine map x -> [x, 1] @
        motion that moved the nodes here from the previous mesh (the mid nodes follow)."""
        nonlocal mid_xyz, supports
        if motion is not None:
            mid_xyz = mid_xyz @ motion[:3] + motion[3]
            supports = {n: s.moved(motion[:3].T, motion[3]) for n, s in supports.items()}
        try:
            return Mesh(model=model, points=xyz, tetrahedra=cells["tetra"],
                        hexahedra=cells["hexahedron"], wedges=cells["wedge"],
                        bodies=body_index, node_sets=node_sets, cyclic=cyclic or {},
                        parameters=parameters, curved_edges=curved, edge_nodes=mid_xyz,
                        supports=supports)
        except MeshValidationError as exc:
            raise MeshImportError(f"{path}: {exc}") from None

    mesh = mesh_of(points[used] * length)
    for name, selection in (sets or {}).items():
        if name in node_sets:
            raise MeshImportError(f"geometry.sets.{name}: the file has a set of that name")
        if selection.body is not None and selection.body not in mesh.bodies:
            raise MeshImportError(f"geometry.sets.{name}.body = {selection.body!r}: not a "
                                  f"body; bodies: {sorted(mesh.bodies)}")
        if selection.radius is not None and sector is None:
            raise MeshImportError(f"geometry.sets.{name}.radius: needs [geometry.sector] "
                                  "(the axis it is measured from)")
        node_sets[name] = selection.nodes(mesh, sector)
        if not node_sets[name].size:
            raise MeshImportError(f"geometry.sets.{name}: selects no surface node (widen "
                                  "the region or its tolerance)")
    if sector is not None:  # (the mesh in the sector's frame holds the chosen sets too)
        rotation, origin = sector_frame(sector.axis, sector.origin)
        mesh = mesh_of((mesh.points - origin) @ rotation.T, None,
                       np.vstack([rotation.T, -origin @ rotation.T]))
        try:
            xyz, boundaries = cyclic_boundaries(mesh, sector)
        except SectorError as exc:
            raise MeshImportError(str(exc)) from None
        if not boundaries:
            raise MeshImportError(
                f"geometry.sector: no body of {path} has two faces on planes through the axis "
                f"{list(sector.axis)} 2 pi / {sector.sectors} apart; name them in "
                "[geometry.sector.faces]")
        centre = centring(xyz, boundaries, sector.angle)
        parameters["frame"] = {"rotation": (centre @ rotation).tolist(),
                               "origin": origin.tolist(), "sectors": sector.sectors}
        mesh = mesh_of(xyz @ centre.T, boundaries, np.vstack([centre.T, np.zeros(3)]))
    elif sets:
        mesh = mesh_of(mesh.points)  # with the chosen sets
    count = {b.type: 0 for _, b in solids}
    for _, b in solids:
        count[b.type] += len(b.data)
    skipped = dict((getattr(raw, "info", None) or {}).get("skipped", {}))
    return ImportedMesh(mesh, ImportReport(count, offset, dropped, skipped, len(curved)))


# VTK cell type -> meshio type, of the solids an Ansys archive holds (a degenerate SOLID185 /
# SOLID186 reads as the wedge or tetrahedron it is)
_VTK_SOLIDS = {10: "tetra", 24: "tetra10", 12: "hexahedron", 25: "hexahedron20",
               13: "wedge", 26: "wedge15", 14: "pyramid"}


def _ansys_archive(path: Path):
    """An Ansys archive (.cdb, MAPDL's CDWRITE and Workbench's export) as a meshio.Mesh, read
    with ansys-mapdl-reader: node components as point sets, element components and material
    ids (``mat<N>``) as element groups."""
    import meshio

    try:
        from ansys.mapdl.reader import Archive
    except ImportError:
        raise MeshImportError(f"{path}: reading .cdb needs ansys-mapdl-reader "
                              "(pip install ansys-mapdl-reader)") from None
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            archive = Archive(str(path))
            grid = archive.grid
    except Exception as exc:  # its parser raises what the file makes it raise
        raise MeshImportError(f"{path}: not a readable Ansys archive ({exc})") from None
    kinds = np.asarray(grid.celltypes)
    unknown = sorted({int(k) for k in kinds} - set(_VTK_SOLIDS))
    if unknown:
        raise MeshImportError(f"{path}: VTK cell type(s) {unknown} not supported (solids: "
                              "tetrahedra, hexahedra, wedges)")
    numbers = np.asarray(grid.point_data["ansys_node_num"])
    index = {int(n): i for i, n in enumerate(numbers)}
    elems = np.asarray(grid.cell_data["ansys_elem_num"])
    mats = np.asarray(grid.cell_data["ansys_material_type"])
    offsets, conn = np.asarray(grid.cell_offsets), np.asarray(grid.cell_connectivity)
    cells, cell_ids, cell_mats = [], [], []
    for vtk in sorted(set(kinds.tolist())):
        rows = np.flatnonzero(kinds == vtk)
        width = offsets[rows[0] + 1] - offsets[rows[0]]  # (one type, one node count)
        data = conn[offsets[rows][:, None] + np.arange(width)]
        if vtk == 13:  # VTK's wedge mirrors ours (and Abaqus', Gmsh's)
            data = data[:, elements.MIRROR["wedge"]]
        cells.append((_VTK_SOLIDS[vtk], data))
        cell_ids.append(elems[rows])
        cell_mats.append(mats[rows])
    point_sets = {name: np.array([index[int(n)] for n in nodes if int(n) in index])
                  for name, nodes in archive.node_components.items()}
    cell_sets = {name: [np.flatnonzero(np.isin(ids, np.asarray(members))) for ids in cell_ids]
                 for name, members in archive.element_components.items()}
    for m in np.unique(mats):
        cell_sets[f"mat{int(m)}"] = [np.flatnonzero(cm == m) for cm in cell_mats]
    try:
        held = _held_nodes(deck_supports.ansys, path, numbers)
    except deck_supports.SupportError as exc:
        raise MeshImportError(str(exc)) from None
    return meshio.Mesh(np.asarray(grid.points, dtype=np.float64), cells,
                       point_sets=point_sets, cell_sets=cell_sets,
                       info={"element_materials": cell_mats,
                             "materials": _cards(materials.ansys, path), "boundary": held})


def _held_nodes(reader, path: Path, ids) -> list[tuple[list[int], tuple[int, ...], str]]:
    """A deck's supports (``geometry.deck_supports``) on the file's node indices (``ids``:
    each point's number in the file); a support of a node the mesh lacks holds nothing."""
    found = reader(path)
    if not found or ids is None:
        return []
    index = {int(n): i for i, n in enumerate(np.asarray(ids))}
    return [([index[n] for n in nodes if n in index], dofs, where)
            for nodes, dofs, where in found]


def _cards(reader, path: Path) -> dict | str:
    """The material cards ``reader`` finds, or why it could not read them (a bad card spoils
    ``material = "file"`` only, not the mesh)."""
    try:
        return reader(path)
    except (ValueError, IndexError) as exc:
        return f"its material cards cannot be read ({exc})"


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


def _bodies(groups, solids, raw, names, path) -> dict[str, dict[int, np.ndarray]]:
    """Body name -> solid block position (in ``solids``) -> element indices in that block."""
    position = {i: k for k, (i, _) in enumerate(solids)}
    total = sum(len(b.data) for _, b in solids)
    solid_groups = {name: {position[i]: idx for i, idx in g.items() if i in position}
                    for name, g in groups.items()}
    solid_groups = {n: g for n, g in solid_groups.items() if g}
    sizes = {n: sum(len(v) for v in g.values()) for n, g in solid_groups.items()}
    listing = ", ".join(f"{n} ({sizes[n]})" for n in sorted(solid_groups)) or "none"
    if names is not None:
        missing = [g for g in names.values() if g not in solid_groups]
        if missing:
            raise MeshImportError(f"geometry.bodies: {missing} are not element groups of "
                                  f"{path}; its element groups: {listing}")
        chosen = {n: solid_groups[g] for n, g in names.items()}
    elif not solid_groups:
        chosen = {"body": {k: np.arange(len(b.data)) for k, (_, b) in enumerate(solids)}}
    else:
        # a group repeated under another name (Gmsh's "Volume1" beside its physical name)
        # counts once, by its last name: the explicit sets come after the element cards
        distinct = {_key(g): n for n, g in solid_groups.items()}
        unique = {n: solid_groups[n] for n in distinct.values()}
        # the finest partition of bodies in contact, else the coarsest (a deck's extra
        # element sets, for loads or surfaces, beside its parts)
        covering = [c for c in (_finest_partition(unique, sizes),
                                _largest_first(unique, sizes))
                    if sum(sizes[n] for n in c) == total]
        chosen = next((c for c in covering if not _share_nodes(c, solids)), None) or \
            (covering[-1] if covering else {})
        if not covering:
            raise MeshImportError(f"{path}: {_why_unclear(unique, total)}, so the bodies are "
                                  f"not clear; name them in geometry.bodies, e.g. bodies = "
                                  f"{{ blade = \"<group>\" }} (element groups: {listing})")
    covered = sum(sum(len(v) for v in g.values()) for g in chosen.values())
    if covered != total or any(not _disjoint(g, h) for n, g in chosen.items()
                               for m, h in chosen.items() if n < m):
        raise MeshImportError(f"geometry.bodies = {sorted(chosen)}: must hold every solid "
                              f"element of {path} once ({total} elements)")
    for name in chosen:
        if not _NAME.match(name):
            raise MeshImportError(f"{path}: body name {name!r} must be letters, digits, "
                                  "'_', '.', '-'")
    nodes = {n: np.unique(np.concatenate([np.asarray(solids[k][1].data)[idx].ravel()
                                          for k, idx in g.items()])) for n, g in chosen.items()}
    for n in chosen:
        for m in chosen:
            shared = np.intersect1d(nodes[n], nodes[m]).size if n < m else 0
            if shared:
                raise MeshImportError(
                    f"{path}: bodies {n!r} and {m!r} share {shared} nodes; bodies in contact "
                    "carry distinct, coincident nodes (or make them one body: name a group "
                    "holding both in geometry.bodies)")
    return chosen


def _finest_partition(groups: dict[str, dict[int, np.ndarray]], sizes: dict[str, int]
                      ) -> dict[str, dict[int, np.ndarray]]:
    """The groups left when the largest of those that overlap another is dropped, until none
    overlaps: a group of every element (Abaqus' EALL) beside the parts gives way to them."""
    left = dict(groups)
    while True:
        overlapping = [n for n in left if any(not _disjoint(left[n], left[m])
                                              for m in left if m != n)]
        if not overlapping:
            return left
        del left[max(overlapping, key=lambda n: (sizes[n], n))]


def _largest_first(groups: dict[str, dict[int, np.ndarray]], sizes: dict[str, int]
                   ) -> dict[str, dict[int, np.ndarray]]:
    """The groups taken largest first, each disjoint from those taken."""
    taken: dict[str, dict[int, np.ndarray]] = {}
    for n in sorted(groups, key=lambda n: (-sizes[n], n)):
        if all(_disjoint(groups[n], g) for g in taken.values()):
            taken[n] = groups[n]
    return taken


def _share_nodes(groups: dict[str, dict[int, np.ndarray]], solids) -> bool:
    """Whether two of the groups share a node."""
    seen: set[int] = set()
    for g in groups.values():
        nodes = set(np.concatenate([np.asarray(solids[k][1].data)[idx].ravel()
                                    for k, idx in g.items()]).tolist())
        if nodes & seen:
            return True
        seen |= nodes
    return False


def _why_unclear(groups: dict[str, dict[int, np.ndarray]], total: int) -> str:
    """Why the element groups are not the bodies: the first pair that overlaps (how many
    elements in both), or how many elements no group holds."""
    names = sorted(groups)
    for i, n in enumerate(names):
        for m in names[i + 1:]:
            both = sum(np.intersect1d(groups[n][k], groups[m][k]).size
                       for k in groups[n].keys() & groups[m].keys())
            if both:
                return (f"element groups {n!r} and {m!r} overlap ({both} elements in both: a "
                        "group of all elements, or a material beside a part?)")
    held = sum(sum(len(v) for v in g.values()) for g in groups.values())
    return f"{total - held} of its {total} solid elements are in no element group"


def _key(g: dict[int, np.ndarray]) -> tuple:
    """A hashable identity of a group of elements."""
    return tuple((k, np.sort(g[k]).tobytes()) for k in sorted(g))


def _disjoint(g: dict[int, np.ndarray], h: dict[int, np.ndarray]) -> bool:
    return all(np.intersect1d(g[k], h[k]).size == 0 for k in g.keys() & h.keys())


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
