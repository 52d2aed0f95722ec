"""A mesh file of any format read as a meshio.Mesh, with what its deck says besides the
elements (materials, supports): CalculiX/Abaqus ``.inp`` (``geometry.abaqus``), Ansys
archives ``.cdb`` (ansys-mapdl-reader), Nastran, Gmsh and everything meshio reads, CAD files
meshed by ``geometry.cad``. :mod:`geometry.imported` makes the Mesh of it."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np

from . import abaqus, cad, deck_supports, elements, materials
from .params import GeometryBuildError
from .sector import SectorSpec


class MeshImportError(ValueError):
    """A mesh file cannot be read into a Mesh; the message is one line naming what and why."""


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
