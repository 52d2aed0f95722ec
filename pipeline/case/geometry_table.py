"""The [geometry] table of a case: a parametric model, or a mesh the user brings.

    [geometry]                       # a parametric model
    model = "blisk_sector"           # a key of geometry.MODELS
    [geometry.parameters]            # its parameters (geometry.PARAMETERS: units, ranges)

    [geometry]                       # an imported mesh (geometry.imported)
    model = "import"
    file = "blade.inp"               # relative to the case file: .inp .cdb .bdf .msh ...,
                                     # or CAD: .step .stp .iges .igs .brep (meshed by Gmsh)
    size = 0.004                     # [m] CAD only: element size (default: extent / 10)
    units = "mm-t-s"                 # the file's units: SI, mm-t-s, mm-kg-s, in-lbf-s
    bodies = ["BLADE", "DISK"]       # optional: the element groups that are the bodies, or
                                     # a table body = "group" (Nastran: "pid<N>")
    [geometry.sector]                # optional: the mesh is one sector of Ns
    sectors = 24
    axis = [1.0, 0.0, 0.0]           # the disk axis, through
    origin = [0.0, 0.0, 0.0]         # [m]
    tolerance = 1e-6                 # [m] node matching
    [geometry.sector.faces]          # optional per body: its cyclic faces' node sets (left,
    disk = ["CYC_L", "CYC_R"]        # right = left rotated by +2 pi / Ns about the axis);
                                     # found by geometry (planar faces) otherwise
    [geometry.sets."disk/bore"]      # optional: node sets chosen by geometry, in metres in
    radius = 0.05                    # the file's frame: surface nodes near a cylinder about
    tolerance = 1e-5                 # the axis (radius), a plane (plane = {point, normal})
    body = "disk"                    # or in a box (box = [[x0, y0, z0], [x1, y1, z1]])

    [geometry.contacts.firtree_left] # optional, any model: a contact between named surfaces
    surfaces = ["blade/flank_l", "disk/slot_l"]  # two node sets (one, with ground = true)
    bodies = ["blade", "disk"]       # optional: their bodies (default: the body each is a
                                     # face of)
    ground = false                   # true: the one surface against the rigid ground
    neighbour = false                # true: the second surface is the neighbouring
                                     # sector's (a shroud interlock, a damper's far flank)
    tolerance = 1e-5                 # [m] optional: how far beyond the other surface a
                                     # point may project and still touch it
    spread = "area"                  # the stiffness shared by tributary area, or "nodes":
                                     # equally (what a model's structured patch does)
    spacing = 0.004                  # [m] optional: contact points about this far apart,
                                     # each the average of a patch of both surfaces (the
                                     # contact grid apart from the mesh; default 0: every
                                     # node of the finer surface is a point)

Each contact is then named like a model's patch in [[assembly.contacts]] (``patch``).

Every number of a case is SI; only the mesh file is in its own units. ``check`` reads the
file (it is quick beside a reduction) so that a missing set or an unmatched face is one line
before any heavy work; the mesh read is kept for the run (keyed by the file's path, size and
modification time).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from microslip import geometry
from microslip.geometry.averaging import averaged_surfaces
from microslip.geometry.boundaries import SurfaceContact
from microslip.geometry.imported import (
    UNITS,
    ImportedMesh,
    MeshImportError,
    Selection,
    import_mesh,
)
from microslip.geometry.pairing import declare_contact, paired_contact
from microslip.geometry.sector import SectorSpec

from .checks import is_int, is_number, unknown_keys

IMPORT = "import"
PARAMETRIC_KEYS = {"model", "parameters", "contacts"}
IMPORT_KEYS = {"model", "file", "units", "bodies", "sector", "sets", "size", "contacts"}
CONTACT_KEYS = {"surfaces", "bodies", "ground", "neighbour", "tolerance", "spread",
                "spacing"}
SECTOR_KEYS = {"sectors", "axis", "origin", "tolerance", "faces"}
SELECTION_KEYS = {"box", "plane", "radius", "tolerance", "body"}


@dataclass(frozen=True)
class ContactDeclaration:
    """[geometry.contacts.<name>] (see the module): what ``geometry.pairing.declare_contact``
    resolves on the mesh."""

    name: str
    surfaces: tuple[str, ...]
    bodies: tuple[str, ...] | None = None
    ground: bool = False
    neighbour: bool = False
    tolerance: float = 0.0  # [m] (0: the pairing's default)
    spread: str = "area"  # the stiffness shared by tributary area, or equally ("nodes")
    spacing: float = 0.0  # [m] points averaging patches this wide (0: side a's nodes)

    def declare(self, mesh: geometry.Mesh) -> SurfaceContact:
        """The contact on ``mesh`` (ValueError naming the key and the fault)."""
        try:
            return declare_contact(mesh, self.name, self.surfaces, self.bodies, self.ground,
                                   self.neighbour, self.tolerance, self.spread)
        except ValueError as err:
            raise ValueError(f"geometry.{err}") from None


def with_contacts(mesh: geometry.Mesh, contacts: tuple[ContactDeclaration, ...]
                  ) -> geometry.Mesh:
    """``mesh`` with the declared contacts added to its own (ValueError naming a fault)."""
    if not contacts:
        return mesh
    added = {}
    for c in contacts:
        if c.name in mesh.contacts:
            raise ValueError(f"geometry.contacts.{c.name}: the model has a contact patch of "
                             "that name already; choose another")
        added[c.name] = c.declare(mesh)
    out = replace(mesh, contacts={**mesh.contacts, **added})
    for name in added:  # the pairing: the surfaces face each other, or a line says why
        try:
            paired_contact(out, name)
        except ValueError as err:
            raise ValueError(f"geometry.{err}") from None
    for c in contacts:
        if c.spacing > 0.0:
            try:
                out = averaged_surfaces(out, c.name, c.spacing)
            except ValueError as err:
                raise ValueError(f"geometry.{err}") from None
    return out


@dataclass(frozen=True)
class GeometryTable:
    """[geometry], read (see the module). ``base``: the case file's folder (``file`` is
    relative to it)."""

    model: str
    parameters: Mapping[str, Any] = field(default_factory=dict)
    file: str = ""
    units: str = "SI"
    bodies: tuple[tuple[str, str], ...] | None = None  # (body name, element group)
    sector: SectorSpec | None = None
    sets: tuple[tuple[str, Selection], ...] = ()
    size: float | None = None  # [m] a CAD file's element size (None: a tenth of its extent)
    base: Path = Path(".")
    contacts: tuple[ContactDeclaration, ...] = ()

    @classmethod
    def of(cls, table: Mapping[str, Any], base: str | Path = ".") -> GeometryTable:
        """The spec of a validated [geometry] table."""
        contacts = tuple(ContactDeclaration(
            name, tuple(t["surfaces"]), tuple(t["bodies"]) if "bodies" in t else None,
            bool(t.get("ground", False)), bool(t.get("neighbour", False)),
            float(t.get("tolerance", 0.0)), t.get("spread", ContactDeclaration.spread),
            float(t.get("spacing", 0.0)))
            for name, t in table.get("contacts", {}).items())
        if table["model"] != IMPORT:
            return cls(table["model"], dict(table.get("parameters", {})), base=Path(base),
                       contacts=contacts)
        bodies = table.get("bodies")
        if isinstance(bodies, list):
            bodies = tuple((b, b) for b in bodies)
        elif isinstance(bodies, dict):
            bodies = tuple(bodies.items())
        sector = table.get("sector")
        if sector is not None:
            sector = SectorSpec(
                int(sector["sectors"]), tuple(map(float, sector.get("axis", SectorSpec.axis))),
                tuple(map(float, sector.get("origin", SectorSpec.origin))),
                tuple((b, *f) for b, f in sector.get("faces", {}).items()),
                float(sector.get("tolerance", SectorSpec.tolerance)))
        sets = tuple((name, _selection(t)) for name, t in table.get("sets", {}).items())
        size = float(table["size"]) if "size" in table else None
        return cls(IMPORT, {}, table["file"], table.get("units", cls.units), bodies, sector,
                   sets, size, Path(base), contacts)

    @property
    def imported(self) -> bool:
        return self.model == IMPORT

    @property
    def path(self) -> Path:
        """The mesh file (imports)."""
        return (self.base / self.file).resolve()

    def build(self) -> geometry.Mesh:
        """The mesh (Gmsh for a parametric model; read for an import) with the declared
        contacts: the heavy step."""
        if self.imported:  # (check, the estimate, the plan and the run each ask)
            return _imported(self._key, self.units, self.bodies, self.sector, self.sets,
                             self.size, self.contacts)
        return with_contacts(geometry.MODELS[self.model](**self.parameters), self.contacts)

    def read(self) -> ImportedMesh:
        """The imported mesh and what reading it found (kept while the file is unchanged)."""
        return _read(self._key, self.units, self.bodies, self.sector, self.sets, self.size)

    @property
    def _key(self) -> tuple:
        """The file's identity for the caches: path, modification time and size."""
        stat = self.path.stat() if self.path.is_file() else None
        return (str(self.path), stat.st_mtime_ns if stat else 0, stat.st_size if stat else 0)

    @property
    def sectors(self) -> int | None:
        """Ns of the model's cyclic bodies (None: no cyclic symmetry)."""
        if self.imported:
            return self.sector.sectors if self.sector else None
        given = self.parameters.get("sectors")
        value = given if given is not None else getattr(geometry.PARAMETERS[self.model](),
                                                        "sectors", None)
        return int(value) if is_int(value) and value >= 3 else None


#: How many names a listing shows before "... and N more"
LISTED = 40


def contents_lines(mesh: geometry.Mesh) -> list[str]:
    """What an imported mesh holds, by the names a case uses: its bodies (element count),
    node sets (node count) and supports."""

    def listing(items: list[str]) -> str:
        more = f" ... and {len(items) - LISTED} more" if len(items) > LISTED else ""
        return ", ".join(items[:LISTED]) + more if items else "none"

    bodies = [f"{b} ({len(mesh.bodies[b])} elements)" for b in sorted(mesh.bodies)]
    sets = [f"{n} ({len(mesh.node_sets[n])})" for n in sorted(mesh.node_sets)]
    lines = [f"bodies: {listing(bodies)}", f"node sets: {listing(sets)}"]
    for name, support in sorted(mesh.supports.items()):
        lines.append(f"support {name} (the file's): {support.describe()}")
    return lines


def imported_contents(data: Mapping[str, Any]) -> list[str]:
    """``contents_lines`` of a valid case's imported mesh, each naming the file (none for a
    parametric model)."""
    geo = data.get("geometry")
    if not (isinstance(geo, Mapping) and geo.get("model") == "import"):
        return []
    table = GeometryTable.of(geo)
    return [f"{Path(table.file).name}: {line}" for line in contents_lines(table.build())]


def _selection(t: Mapping[str, Any]) -> Selection:
    def point(v) -> tuple[float, ...]:
        return tuple(float(x) for x in v)

    plane = t.get("plane")
    return Selection(
        box=tuple(point(c) for c in t["box"]) if "box" in t else None,
        plane=(point(plane["point"]), point(plane["normal"])) if plane else None,
        radius=float(t["radius"]) if "radius" in t else None,
        tolerance=float(t.get("tolerance", Selection.tolerance)), body=t.get("body"))


@functools.lru_cache(maxsize=4)
def _read(key: tuple, units: str, bodies, sector, sets, size) -> ImportedMesh:
    return import_mesh(key[0], units, dict(bodies) if bodies is not None else None, sector,
                       dict(sets), size)


@functools.lru_cache(maxsize=4)
def _imported(key: tuple, units: str, bodies, sector, sets, size,
              contacts: tuple[ContactDeclaration, ...]) -> geometry.Mesh:
    """The imported mesh with its declared contacts (a fault raises, and is not kept)."""
    return with_contacts(_read(key, units, bodies, sector, sets, size).mesh, contacts)


def check(geo: Any, base: str | Path, out: list[str]) -> GeometryTable | None:
    """Append one line per fault of [geometry] to ``out``; the table's spec when it has
    none (an import is read: the file, its units, bodies and cyclic faces checked)."""
    models = sorted([*geometry.MODELS, IMPORT])
    if not isinstance(geo, dict) or geo.get("model") not in models:
        out.append(f"geometry.model = {geo.get('model') if isinstance(geo, dict) else geo!r}: "
                   f"expected one of {models}")
        return None
    if geo["model"] != IMPORT:
        unknown_keys("geometry.", geo, PARAMETRIC_KEYS, out)
        if not isinstance(geo.get("parameters", {}), dict):
            out.append("geometry.parameters: expected a table")
            return None
        before = len(out)
        check_parameters(geo["model"], geo.get("parameters", {}), out)
        _check_contacts(geo.get("contacts", {}), out)
        return GeometryTable.of(geo, base) if len(out) == before else None
    before = len(out)
    unknown_keys("geometry.", geo, IMPORT_KEYS, out)
    if not isinstance(geo.get("file"), str) or not geo.get("file"):
        out.append(f"geometry.file = {geo.get('file')!r}: expected the mesh file's path "
                   "(relative to the case file)")
    elif not (Path(base) / geo["file"]).is_file():
        out.append(f"geometry.file = {geo['file']!r}: no such file" + (
            "" if Path(geo["file"]).is_absolute()
            else f" (looked for {(Path(base) / geo['file']).resolve()})"))
    if geo.get("units", "SI") not in UNITS:
        out.append(f"geometry.units = {geo['units']!r}: expected one of {list(UNITS)}")
    bodies = geo.get("bodies")
    if bodies is not None and not (
            (isinstance(bodies, list) and bodies and all(isinstance(b, str) for b in bodies))
            or (isinstance(bodies, dict) and bodies
                and all(isinstance(b, str) for b in bodies.values()))):
        out.append(f"geometry.bodies = {bodies!r}: expected a list of element-group names or a "
                   "table body = \"group\"")
    if "sector" in geo:
        _check_sector(geo["sector"], out)
    if "size" in geo and not (is_number(geo["size"]) and geo["size"] > 0):
        out.append(f"geometry.size = {geo['size']!r}: expected an element size > 0 [m] (CAD "
                   "files)")
    sets = geo.get("sets", {})
    if not isinstance(sets, dict):
        out.append("geometry.sets: expected a table of node sets chosen by geometry")
    else:
        for name, t in sets.items():
            _check_selection(f"geometry.sets.{name}", t, out)
    _check_contacts(geo.get("contacts", {}), out)
    if len(out) > before:
        return None
    table = GeometryTable.of(geo, base)
    try:
        table.build()
    except MeshImportError as exc:
        out.append(f"geometry.file: {exc}")  # (the message names the file)
        return None
    except ValueError as exc:  # a declared contact (the message names it)
        out.append(str(exc))
        return None
    return table


def check_parameters(model: str, given: Mapping[str, Any], out: list[str]) -> None:
    """The faults of a parametric model's [geometry.parameters], as the model would meet
    them before meshing: unknown names, then each value's type and range and the rules
    between values (the parameter class's ``validate``), one line each."""
    cls = geometry.PARAMETERS[model]
    names = {f.name for f in dataclasses.fields(cls)}
    before = len(out)
    unknown_keys("geometry.parameters.", given, names, out)
    if len(out) > before:
        return
    try:
        cls(**given).validate()
    except geometry.GeometryParameterError as err:  # "<Class>.name = v: ..." or "name = v"
        text = str(err).removeprefix(f"{cls.__name__}.")
        out.append(f"geometry.parameters.{text}")


def _check_contacts(contacts: Any, out: list[str]) -> None:
    """The declarations' form (what they name is checked on the mesh)."""
    if not isinstance(contacts, dict) or not all(isinstance(t, dict)
                                                 for t in contacts.values()):
        out.append("geometry.contacts: expected tables [geometry.contacts.<name>]")
        return
    for name, t in contacts.items():
        pre = f"geometry.contacts.{name}"
        unknown_keys(f"{pre}.", t, CONTACT_KEYS, out)
        for key in ("ground", "neighbour"):
            if not isinstance(t.get(key, False), bool):
                out.append(f"{pre}.{key} = {t[key]!r}: expected true or false")
        want = 1 if t.get("ground") is True else 2
        surfaces = t.get("surfaces")
        if not (isinstance(surfaces, list) and len(surfaces) == want
                and all(isinstance(x, str) for x in surfaces)):
            out.append(f"{pre}.surfaces = {surfaces!r}: expected {want} node-set name"
                       + ("s" if want > 1 else " (ground = true)"))
        bodies = t.get("bodies", [""] * want)
        if not (isinstance(bodies, list) and len(bodies) == want
                and all(isinstance(x, str) for x in bodies)):
            out.append(f"{pre}.bodies = {bodies!r}: expected {want} body name"
                       + ("s, one per surface" if want > 1 else ""))
        if t.get("ground") is True and t.get("neighbour") is True:
            out.append(f"{pre}: ground and neighbour exclude each other")
        tol = t.get("tolerance", 1.0)
        if not (is_number(tol) and tol > 0):
            out.append(f"{pre}.tolerance = {tol!r}: expected a distance > 0 [m]")
        spacing = t.get("spacing", 0.0)
        if not (is_number(spacing) and spacing >= 0):
            out.append(f"{pre}.spacing = {spacing!r}: expected a distance >= 0 [m] (0: "
                       "every node of the finer surface a contact point)")
        if t.get("spread", "area") not in ("area", "nodes"):
            out.append(f"{pre}.spread = {t['spread']!r}: expected \"area\" (the stiffness "
                       "by tributary area) or \"nodes\" (equal shares)")


def _vector(v: Any) -> bool:
    return isinstance(v, list) and len(v) == 3 and all(is_number(x) for x in v)


def _check_selection(pre: str, t: Any, out: list[str]) -> None:
    if not isinstance(t, dict):
        out.append(f"{pre}: expected a table (box, plane or radius; tolerance, body)")
        return
    unknown_keys(f"{pre}.", t, SELECTION_KEYS, out)
    if not {"box", "plane", "radius"} & set(t):
        out.append(f"{pre}: give its region: box, plane or radius")
    box = t.get("box", [[0, 0, 0], [0, 0, 0]])
    if not (isinstance(box, list) and len(box) == 2 and all(_vector(c) for c in box)):
        out.append(f"{pre}.box = {box!r}: expected [[x0, y0, z0], [x1, y1, z1]] [m]")
    plane = t.get("plane", {"point": [0, 0, 0], "normal": [0, 0, 1]})
    if not (isinstance(plane, dict) and set(plane) == {"point", "normal"}
            and _vector(plane["point"]) and _vector(plane["normal"])
            and math.hypot(*plane["normal"]) > 0):
        out.append(f"{pre}.plane = {plane!r}: expected {{point = [x, y, z], normal = "
                   "[nx, ny, nz]}} [m]")
    if "radius" in t and not (is_number(t["radius"]) and t["radius"] > 0):
        out.append(f"{pre}.radius = {t['radius']!r}: expected a radius > 0 [m]")
    tol = t.get("tolerance", Selection.tolerance)
    if not (is_number(tol) and tol > 0):
        out.append(f"{pre}.tolerance = {tol!r}: expected a distance > 0 [m]")
    if "body" in t and not isinstance(t["body"], str):
        out.append(f"{pre}.body = {t['body']!r}: expected a body name")


def _check_sector(sector: Any, out: list[str]) -> None:
    if not isinstance(sector, dict):
        out.append("geometry.sector: expected a table (sectors, axis, origin, tolerance, faces)")
        return
    unknown_keys("geometry.sector.", sector, SECTOR_KEYS, out)
    n = sector.get("sectors")
    if not (is_int(n) and n >= 3):
        out.append(f"geometry.sector.sectors = {n!r}: expected an integer >= 3 (the sector "
                   "count of the full disk)")

    axis = sector.get("axis", [0.0, 0.0, 1.0])
    if not (_vector(axis) and math.hypot(*axis) > 0):
        out.append(f"geometry.sector.axis = {axis!r}: expected a non-zero [ax, ay, az]")
    if not _vector(sector.get("origin", [0.0, 0.0, 0.0])):
        out.append(f"geometry.sector.origin = {sector['origin']!r}: expected a point "
                   "[x, y, z] of the axis [m]")
    tol = sector.get("tolerance", SectorSpec.tolerance)
    if not (is_number(tol) and tol > 0):
        out.append(f"geometry.sector.tolerance = {tol!r}: expected a distance > 0 [m]")
    faces = sector.get("faces", {})
    if not (isinstance(faces, dict) and all(
            isinstance(f, list) and len(f) == 2 and all(isinstance(s, str) for s in f)
            for f in faces.values())):
        out.append(f"geometry.sector.faces = {faces!r}: expected a table body = "
                   "[\"left set\", \"right set\"]")
