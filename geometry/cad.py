"""CAD files (STEP, IGES, BREP) meshed through Gmsh's OpenCASCADE kernel into what the
importer reads (a meshio.Mesh), so a CAD model goes on like any mesh file.

* Units: STEP and IGES declare theirs, and OpenCASCADE converts them; a BREP has none, so
  it is read in the case's ``units``.
* Bodies: each solid; named by the CAD's label (its last part: "Assembly/Blade" -> "Blade")
  or ``body<k>``. IGES files that carry faces rather than solids are sewn into solids (an
  assembly of touching solids then comes back as one: use STEP or BREP for those).
* Touching solids: the geometry is fragmented, so the faces where they touch are meshed
  once (matching node grids); each solid then gets its own copy of those nodes (bodies share
  no node), and each side of an interface is a node set, ``interface/<a>/<b>`` on body a and
  ``interface/<b>/<a>`` on body b, paired node for node.
* Sector: with ``sector``, each face that is the image of another under the rotation by
  2 pi / Ns about the axis is meshed as that image (Gmsh's periodic constraint), so cyclic
  faces match node for node; they are the node sets ``cyclic/<body>/left`` and ``right``.
* Sizes: ``size`` [m] the target element edge (default: a tenth of the smallest solid's
  extent).
"""

from __future__ import annotations

import re
from pathlib import Path

import gmsh
import numpy as np

from . import _gmsh as g
from .params import GeometryBuildError
from .sector import SectorSpec

SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep")
_NAME = re.compile(r"[^A-Za-z0-9_.\-]+")


def mesh(path: str | Path, length: float = 1.0, size: float | None = None,
         sector: SectorSpec | None = None):
    """The CAD file meshed in linear tetrahedra, as a meshio.Mesh (see the module).

    length: metres per length unit of a BREP file (STEP and IGES declare theirs). The points
    stay in the model's unit, ``info["length"]`` metres each (the importer scales them).

    It runs in a fresh process: OpenCASCADE keeps its unit conversion in process-wide state
    (after one STEP file read in metres, every later IGES file is converted too, and asking an
    IGES read for a unit fails before any STEP read), and a malformed file can crash it.
    """
    import concurrent.futures
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as pool:
        try:
            return pool.submit(_mesh_session, str(path), length, size, sector).result()
        except concurrent.futures.process.BrokenProcessPool:
            raise GeometryBuildError(f"{path}: Gmsh crashed reading or meshing it") from None


def _mesh_session(path: str, length: float, size: float | None, sector: SectorSpec | None):
    """(In the child process) one Gmsh session: read, mesh, read back."""
    with g.gmsh_session("cad"):
        try:
            return _mesh(Path(path), length, size, sector)
        except GeometryBuildError:
            raise
        except Exception as exc:  # Gmsh and OpenCASCADE raise plain Exception
            why = str(exc) or type(exc).__name__
            raise GeometryBuildError(f"{path}: Gmsh could not read or mesh it ({why})") from None


def _mesh(path: Path, length: float, size: float | None, sector: SectorSpec | None):
    import meshio

    occ = gmsh.model.occ
    kind = path.suffix.lower()
    # metres per model unit: a BREP's is the case's; in a fresh process OpenCASCADE converts
    # STEP to metres when asked, IGES (which refuses the request) to millimetres
    scale = {".brep": length, ".iges": 1e-3, ".igs": 1e-3}.get(kind, 1.0)
    gmsh.option.setString("Geometry.OCCTargetUnit", "M" if kind in (".step", ".stp") else "")
    shapes = occ.importShapes(str(path))
    occ.synchronize()
    if not gmsh.model.getEntities(3) and gmsh.model.getEntities(2):  # faces only: sew
        occ.healShapes(sewFaces=True, makeSolids=True)
        occ.synchronize()
    volumes = [t for _, t in gmsh.model.getEntities(3)]
    if not volumes:
        raise GeometryBuildError(f"{path}: no solid (it holds {len(shapes)} shapes of lower "
                                 "dimension)")
    names = _body_names(volumes)
    owner = {v: names[v] for v in volumes}  # volume (after fragment) -> body name
    if len(volumes) > 1:  # touching solids: their common faces meshed once
        _, mapping = occ.fragment([(3, v) for v in volumes], [])
        occ.synchronize()
        owner = {tag: names[v] for v, pieces in zip(volumes, mapping, strict=True)
                 for dim, tag in pieces if dim == 3}
    periodic = _periodic_faces(sector, scale) if sector is not None else []
    extent = min(np.ptp(np.array(gmsh.model.getBoundingBox(3, v)).reshape(2, 3), axis=0).max()
                 for v in owner)
    h = size / scale if size is not None else extent / 10.0
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h / 10.0)
    gmsh.model.mesh.generate(3)
    raw = _read_back(owner, periodic, meshio)
    raw.info = {"length": scale}
    return raw


def _body_names(volumes: list[int]) -> dict[int, str]:
    """Volume -> a body name: the label's last part, made unique; body<k> without one."""
    names, seen = {}, set()
    for k, v in enumerate(volumes, 1):
        label = gmsh.model.getEntityName(3, v).split("/")[-1].strip()
        name = _NAME.sub("_", label) if label and "translator" not in label else f"body{k}"
        while name in seen:
            name += f"_{k}"
        seen.add(name)
        names[v] = name
    return names


def _rotation(sector: SectorSpec, scale: float) -> np.ndarray:
    """4x4 affine of the rotation by 2 pi / Ns about the sector's axis through its origin
    ([m]; the model is in units of ``scale`` metres)."""
    a = np.asarray(sector.axis, dtype=float)
    a /= np.linalg.norm(a)
    phi = sector.angle
    ax = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    R = np.eye(3) + np.sin(phi) * ax + (1 - np.cos(phi)) * ax @ ax
    o = np.asarray(sector.origin, dtype=float) / scale
    affine = np.eye(4)
    affine[:3, :3] = R
    affine[:3, 3] = o - R @ o
    return affine


def _periodic_faces(sector: SectorSpec, scale: float) -> list[tuple[int, int]]:
    """(left face, right face) pairs, right = the left turned by 2 pi / Ns; each set
    periodic so that its mesh is the left one's image."""
    affine = _rotation(sector, scale)
    faces = [t for _, t in gmsh.model.getEntities(2)]
    centre = {t: np.array(gmsh.model.occ.getCenterOfMass(2, t)) for t in faces}
    area = {t: gmsh.model.occ.getMass(2, t) for t in faces}
    scale = max(np.abs(np.array(gmsh.model.getBoundingBox(-1, -1))).max(), 1e-300)
    pairs = []
    for left in faces:
        image = affine[:3, :3] @ centre[left] + affine[:3, 3]
        for right in faces:
            if right != left and np.linalg.norm(centre[right] - image) < 1e-6 * scale and \
                    abs(area[right] - area[left]) < 1e-6 * max(area[left], 1e-300):
                gmsh.model.mesh.setPeriodic(2, [right], [left], affine.ravel().tolist())
                pairs.append((left, right))
    return pairs


def _read_back(owner: dict[int, str], periodic: list[tuple[int, int]], meshio):
    """The meshed model as a meshio.Mesh: each body's tetrahedra on its own nodes."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    xyz = np.asarray(xyz).reshape(-1, 3)
    index = {int(t): i for i, t in enumerate(tags)}
    points = [xyz]
    blocks, cell_sets, copies = [], {}, {}  # copies: body -> {node: its copy}
    used: dict[int, str] = {}  # node -> the first body that took it
    bodies = sorted(set(owner.values()))
    for name in bodies:
        tets = [np.asarray(gmsh.model.mesh.getElements(3, v)[2][0], dtype=np.int64)
                for v in owner if owner[v] == name]
        t = np.vectorize(index.__getitem__, otypes=[np.int64])(np.concatenate(tets))
        mine = {}
        for node in np.unique(t).tolist():
            if node in used:  # on an interface: this body gets its own copy
                mine[node] = sum(len(p) for p in points)
                points.append(xyz[node][None])
            else:
                used[node] = name
        copies[name] = mine
        t = np.vectorize(lambda n, m=mine: m.get(n, n), otypes=[np.int64])(t).reshape(-1, 4)
        cell_sets[name] = [np.arange(len(t)) if b == name else np.empty(0, np.int64)
                           for b in bodies]
        blocks.append(("tetra", t))
    point_sets = {}
    for name in bodies:  # each interface's two sides, node for node
        for node, copy in copies[name].items():
            other = used[node]
            point_sets.setdefault(f"interface/{other}/{name}", []).append(node)
            point_sets.setdefault(f"interface/{name}/{other}", []).append(copy)
    for left, right in periodic:
        body = next(owner[v] for v in owner if left in _faces_of(v))
        for side, face in (("left", left), ("right", right)):
            nodes = gmsh.model.mesh.getNodes(2, face, includeBoundary=True)[0]
            point_sets.setdefault(f"cyclic/{body}/{side}", []).extend(
                copies[body].get(index[int(n)], index[int(n)]) for n in nodes)
    for dim, tag in gmsh.model.getEntities(2):  # faces the CAD names, on their body's nodes
        label = gmsh.model.getEntityName(dim, tag).split("/")[-1].strip()
        if label:
            body = next(owner[v] for v in owner if tag in _faces_of(v))
            nodes = gmsh.model.mesh.getNodes(2, tag, includeBoundary=True)[0]
            point_sets.setdefault(_NAME.sub("_", label), []).extend(
                copies[body].get(index[int(n)], index[int(n)]) for n in nodes)
    return meshio.Mesh(np.vstack(points), blocks,
                       point_sets={k: np.unique(v) for k, v in point_sets.items()},
                       cell_sets=cell_sets)


def _faces_of(volume: int) -> set[int]:
    return {abs(t) for _, t in gmsh.model.getBoundary([(3, volume)], oriented=False)}
