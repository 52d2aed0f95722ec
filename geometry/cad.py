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
* Curved faces: the tetrahedra come back with 10 nodes, their mid-edge nodes where Gmsh's
  second-order mesh puts them on the CAD's curved faces and edges (the quadratic geometry
  the importer keeps); a model of planar faces only comes back in 4-node tetrahedra.
"""

from __future__ import annotations

import re
from pathlib import Path

import gmsh
import numpy as np

from . import _gmsh as g
from . import elements
from .mesh import mid_edge_points
from .params import GeometryBuildError
from .sector import SectorSpec

SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep")
_NAME = re.compile(r"[^A-Za-z0-9_.\-]+")


def mesh(path: str | Path, length: float = 1.0, size: float | None = None,
         sector: SectorSpec | None = None):
    """The CAD file meshed in tetrahedra, as a meshio.Mesh (see the module).

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
    r = g.MeshReader()  # the tetrahedra's nodes, 0-based, and each volume's tets
    points = [r.points]
    n = len(r.points)
    blocks, cell_sets, point_sets = [], {}, {}
    taken = np.full(n, -1)  # node -> the first body (index) that took it
    copy_of: dict[str, np.ndarray] = {}  # body -> (n,) its own index of each node
    bodies = sorted(set(owner.values()))
    for k, name in enumerate(bodies):
        t = r.tets([v for v in owner if owner[v] == name])
        mine = np.arange(n)
        nodes = np.unique(t)
        shared = nodes[taken[nodes] >= 0]  # on an interface: this body gets its own copies
        mine[shared] = n + np.arange(len(shared))
        n += len(shared)
        points.append(r.points[shared])
        for other in np.unique(taken[shared]):  # each interface's two sides, node for node
            side = shared[taken[shared] == other]
            point_sets[f"interface/{bodies[other]}/{name}"] = side
            point_sets[f"interface/{name}/{bodies[other]}"] = mine[side]
        taken[nodes[taken[nodes] < 0]] = k
        copy_of[name] = mine
        cell_sets[name] = [np.arange(len(t)) if b == name else np.empty(0, np.int64)
                           for b in bodies]
        if len(r.curved_edges):  # the body's own mid nodes, on the CAD's curved faces
            edges, mids = _mid_nodes(r, t, n)
            n += len(mids)
            points.append(mids)
            blocks.append(("tetra10", np.hstack([mine[t], edges])))
        else:
            blocks.append(("tetra", mine[t]))
    body_of_face = {f: owner[v] for v in owner for f in _faces_of(v)}

    def face_nodes(face: int) -> np.ndarray:
        """A face's nodes, as its own body numbers them."""
        return copy_of[body_of_face[face]][r.surface_nodes([face])]

    for left, right in periodic:
        for side, face in (("left", left), ("right", right)):
            key = f"cyclic/{body_of_face[left]}/{side}"
            point_sets[key] = np.union1d(point_sets.get(key, []), face_nodes(face))
    for dim, tag in gmsh.model.getEntities(2):  # faces the CAD names
        label = gmsh.model.getEntityName(dim, tag).split("/")[-1].strip()
        if label:
            key = _NAME.sub("_", label)
            point_sets[key] = np.union1d(point_sets.get(key, []), face_nodes(tag))
    return meshio.Mesh(np.vstack(points), blocks,
                       point_sets={k: np.asarray(v, dtype=np.int64)
                                   for k, v in point_sets.items()},
                       cell_sets=cell_sets)


def _mid_nodes(r, tets: np.ndarray, first: int) -> tuple[np.ndarray, np.ndarray]:
    """(m, 6) mid-node numbers (from ``first`` on) of the tets (m, 4) and (e, 3) their points:
    Gmsh's second-order points where an edge is curved, the straight midpoint elsewhere."""
    pairs = np.sort(tets[:, elements.EDGES["tetra"]].reshape(-1, 2), axis=1)  # VTK order
    unique, which = np.unique(pairs, axis=0, return_inverse=True)
    xyz = mid_edge_points(r.points, unique, r.curved_edges, r.edge_nodes)
    return first + which.reshape(-1, 6), xyz


def _faces_of(volume: int) -> set[int]:
    return {abs(t) for _, t in gmsh.model.getBoundary([(3, volume)], oriented=False)}
