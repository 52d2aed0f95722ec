"""The one place that opens and closes Gmsh, plus small helpers on an open model.

Every model builder runs inside :func:`gmsh_session`; nothing here holds state
between calls. Helpers read the current Gmsh model and return plain NumPy arrays.
"""

from __future__ import annotations

import contextlib
import json
import signal
import threading
from collections.abc import Callable, Iterator

import gmsh
import numpy as np
from scipy.spatial import cKDTree

from . import elements
from .boundaries import ContactPatch, CyclicBoundary
from .mesh import CURVED, MATCH_TOL, Mesh, rotation_z
from .params import GeometryBuildError

Dimtags = list[tuple[int, int]]


@contextlib.contextmanager
def gmsh_session(model_name: str) -> Iterator[None]:
    """Open a quiet, single-threaded, reproducible Gmsh session; always finalize it."""
    if gmsh.isInitialized():
        raise RuntimeError("a Gmsh session is already open (sessions do not nest)")
    # No config files and no SIGINT hijack: same options on every machine/thread.
    handlers = _signal_handlers()
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        for name, value in (
            ("General.Terminal", 0),
            ("General.Verbosity", 2),
            ("General.NumThreads", 1),
            ("Geometry.OCCParallel", 0),
            ("Mesh.MaxNumThreads1D", 1),
            ("Mesh.MaxNumThreads2D", 1),
            ("Mesh.MaxNumThreads3D", 1),
            ("Mesh.RandomSeed", 1),
            ("Mesh.Algorithm", 6),  # Frontal-Delaunay 2D
            ("Mesh.Algorithm3D", 1),  # Delaunay 3D, deterministic in 1 thread
            ("Mesh.ElementOrder", 1),
            ("Mesh.Optimize", 1),
            # Netgen's optimiser lifts the worst tets near acute wedges (damper, dovetail)
            # from SICN ~0.05 to > 0.18 for ~2x the meshing time; surfaces stay untouched.
            ("Mesh.OptimizeNetgen", 1),
        ):
            gmsh.option.setNumber(name, value)
        # string options outlive a session within the process (a STEP import's unit would
        # then convert the next file): every session starts from the defaults
        gmsh.option.setString("Geometry.OCCTargetUnit", "")
        gmsh.model.add(model_name)
        yield
    finally:
        gmsh.finalize()
        _restore(handlers)


#: Signals whose Python handlers a session must leave in place: Gmsh (OpenCASCADE) installs
#: C-level handlers behind Python's back, and SIGTERM then killed `microslip run` outright
#: instead of saving a partial results file.
SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _signal_handlers() -> dict:
    return {s: signal.getsignal(s) for s in SIGNALS}


def _restore(handlers: dict) -> None:
    if threading.current_thread() is not threading.main_thread():
        return  # only the main thread handles (and may set) signals
    for s, h in handlers.items():
        if h is not None:  # None: set outside Python, nothing of ours to restore
            signal.signal(s, h)


def run_builder(model: str, params: dict, build: Callable[[], Mesh]) -> Mesh:
    """Run ``build`` in a fresh session; report any Gmsh failure with the parameters."""
    try:
        with gmsh_session(model):
            return build()
    except GeometryBuildError:
        raise
    except Exception as exc:  # Gmsh raises plain Exception
        raise GeometryBuildError(
            f"Gmsh failed to build {model!r}: {exc}\nparameters: {json.dumps(params)}"
        ) from exc


# --------------------------------------------------------------- geometry queries
def affine_rotation_z(angle: float) -> list[float]:
    """Row-major 4x4 affine of the rotation by ``angle`` (rad) about +z (for setPeriodic)."""
    a = np.eye(4)
    a[:3, :3] = rotation_z(angle)
    return a.ravel().tolist()


def boundary_surfaces(volumes: Dimtags) -> list[int]:
    """Surface tags bounding the given volumes."""
    faces = gmsh.model.getBoundary(volumes, combined=False, oriented=False, recursive=False)
    return sorted({abs(t) for d, t in faces if d == 2})


def surface_centre(tag: int) -> np.ndarray:
    """(3,) centre of mass of surface ``tag`` (m)."""
    return np.array(gmsh.model.occ.getCenterOfMass(2, tag))


def surfaces_on_plane(surfaces: list[int], origin, normal, tol: float = 1e-9) -> list[int]:
    """Surfaces lying in the plane through ``origin`` with unit ``normal``.

    A surface is on the plane when its bounding box corners' projection on the normal
    and its parametric-centre normal agree with the plane (planar faces only)."""
    origin = np.asarray(origin, float)
    normal = np.asarray(normal, float)
    found = []
    for tag in surfaces:
        if abs((surface_centre(tag) - origin) @ normal) > tol:
            continue
        lo, hi = np.array(gmsh.model.getParametrizationBounds(2, tag))
        samples = np.array([[lo[0], lo[1]], [hi[0], hi[1]], [(lo[0] + hi[0]) / 2, lo[1]]])
        pts = np.array(gmsh.model.getValue(2, tag, samples.ravel().tolist())).reshape(-1, 3)
        n = np.array(gmsh.model.getNormal(tag, [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2]))
        if np.abs((pts - origin) @ normal).max() < tol and abs(abs(n @ normal) - 1) < 1e-9:
            found.append(tag)
    return found


def imprint_faces(volume: int, faces: list[int]) -> int:
    """Split the boundary of ``volume`` by faces lying on it (OCC fragment); the volume's
    new tag. Fails if a face did not land on the boundary (it would stay free)."""
    out, _ = gmsh.model.occ.fragment([(3, volume)], [(2, t) for t in faces])
    vols = [t for d, t in out if d == 3]
    if len(vols) != 1:
        raise GeometryBuildError(f"imprinting split the solid into {len(vols)} volumes")
    occ_boundary = gmsh.model.occ.getEntities(2)
    gmsh.model.occ.synchronize()
    bounded = set(boundary_surfaces([(3, vols[0])]))
    free = [t for _, t in occ_boundary if t not in bounded]
    if free:
        raise GeometryBuildError(f"imprint faces {free} are not on the solid's boundary")
    return vols[0]


def tip_face_and_corners(volume: int, x_tip: float) -> tuple[list[int], int, int]:
    """(tip faces on the plane x = x_tip, corner point with min z, corner with max z)."""
    tip = surfaces_on_plane(boundary_surfaces([(3, volume)]), (x_tip, 0, 0), (1, 0, 0))
    if not tip:
        raise GeometryBuildError(f"no blade tip face at x = {x_tip}")
    pts = gmsh.model.getBoundary([(2, t) for t in tip], combined=False, recursive=True)
    pts = sorted({t for d, t in pts if d == 0})
    z = [gmsh.model.getValue(0, t, [])[2] for t in pts]
    return tip, pts[int(np.argmin(z))], pts[int(np.argmax(z))]


def on_cylinder(surface: int, radius: float, tol: float = 1e-9) -> bool:
    """True if sampled points of the surface all lie at ``radius`` from the z axis."""
    lo, hi = np.array(gmsh.model.getParametrizationBounds(2, surface))
    grid = np.meshgrid(np.linspace(lo[0], hi[0], 3), np.linspace(lo[1], hi[1], 3))
    uv = np.column_stack([grid[0].ravel(), grid[1].ravel()])
    xyz = np.array(gmsh.model.getValue(2, surface, uv.ravel().tolist())).reshape(-1, 3)
    return bool(np.abs(np.hypot(xyz[:, 0], xyz[:, 1]) - radius).max() < tol)


def surface_with_centre(surfaces: list[int], centre, area: float, tol: float = 1e-7) -> int:
    """The unique surface with the given centre of mass and area (identifies imprints)."""
    centre = np.asarray(centre, float)
    hits = [
        t
        for t in surfaces
        if np.linalg.norm(surface_centre(t) - centre) < tol
        and abs(gmsh.model.occ.getMass(2, t) - area) < 1e-6 * area
    ]
    if len(hits) != 1:
        raise GeometryBuildError(f"expected one surface at {centre} of area {area}, got {hits}")
    return hits[0]


def set_transfinite_rectangle(tag: int, e1, n1: int, n2: int) -> None:
    """Structured n1 x n2 grid on a 4-sided planar surface; ``e1`` is the n1 direction."""
    e1 = np.asarray(e1, float) / np.linalg.norm(e1)
    curves = [abs(t) for _, t in gmsh.model.getBoundary([(2, tag)], oriented=False)]
    if len(curves) != 4:
        raise GeometryBuildError(f"surface {tag} has {len(curves)} edges, expected 4")
    for c in curves:
        ends = gmsh.model.getBoundary([(1, c)], oriented=False)
        p0, p1 = (np.array(gmsh.model.getValue(0, t, [])) for _, t in ends)
        along = abs((p1 - p0) @ e1) / np.linalg.norm(p1 - p0)
        gmsh.model.mesh.setTransfiniteCurve(c, n1 if along > 0.5 else n2)
    gmsh.model.mesh.setTransfiniteSurface(tag)


def set_periodic_rotation(left: list[int], right: list[int], angle: float) -> None:
    """Make each right surface the image of its left surface by the rotation ``angle``.

    Faces are paired by rotating the left centres of mass (robust to tag order)."""
    if len(left) != len(right) or not left:
        raise GeometryBuildError(f"cyclic faces do not pair: left {left}, right {right}")
    rot = rotation_z(angle)
    right_c = np.array([surface_centre(t) for t in right])
    for tag in left:
        image = rot @ surface_centre(tag)
        j = int(np.argmin(np.linalg.norm(right_c - image, axis=1)))
        if np.linalg.norm(right_c[j] - image) > 1e-7:
            raise GeometryBuildError(f"no right cyclic face matches left face {tag}")
        gmsh.model.mesh.setPeriodic(2, [right[j]], [tag], affine_rotation_z(angle))


def add_distance_refinement(surfaces: list[int], size_min: float, size_max: float,
                            dist_max: float, dim: int = 2) -> int:
    """Threshold field: size_min on ``surfaces`` (curves with ``dim`` 1) growing to
    size_max at ``dist_max``."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    f.setNumbers(dist, "SurfacesList" if dim == 2 else "CurvesList", surfaces)
    f.setNumber(dist, "Sampling", 20)
    thr = f.add("Threshold")
    f.setNumber(thr, "InField", dist)
    f.setNumber(thr, "SizeMin", size_min)
    f.setNumber(thr, "SizeMax", size_max)
    f.setNumber(thr, "DistMin", 0.0)
    f.setNumber(thr, "DistMax", dist_max)
    return thr


def fillet_root(volume: int, on_root: Callable[[np.ndarray], bool], radius: float) -> int:
    """Round the edges of ``volume`` where its blade meets the platform (``root_edges``) with
    a fillet of ``radius`` [m]; the volume's new tag."""
    out = gmsh.model.occ.fillet([volume], root_edges(volume, on_root), [radius],
                                removeVolume=True)
    gmsh.model.occ.synchronize()
    vols = [t for d, t in out if d == 3]
    if len(vols) != 1:
        raise GeometryBuildError(f"the root fillet left {len(vols)} volumes")
    return vols[0]


def faces_within(volume: int, lo, hi, but_not: Callable[[int], bool]) -> list[int]:
    """The faces of ``volume`` centred in the box [lo, hi] [m] that ``but_not`` does not
    exclude (a fillet's faces: near the root, off the platform's own face)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    out = [t for t in boundary_surfaces([(3, volume)])
           if np.all((lo <= surface_centre(t)) & (surface_centre(t) <= hi)) and not but_not(t)]
    if not out:
        raise GeometryBuildError("no face of the root's fillet found")
    return out


def root_refinement(volume: int, x_root: float, half_y: float, half_z: float,
                    fillet: float, size: float, size_max: float, reach: float,
                    on_platform: Callable[[int], bool],
                    on_root: Callable[[np.ndarray], bool]) -> int:
    """Threshold field at a blade's root, ``size`` graded to ``size_max`` over ``reach``
    [m]: on the faces of its ``fillet`` (centred within the fillet of the root plane x =
    ``x_root`` round the section's half extents, off the platform's own face), or with no
    fillet on its sharp root edges (``root_edges``)."""
    if fillet > 0.0:
        f = fillet
        faces = faces_within(volume, (x_root - f, -half_y - f, -half_z - f),
                             (x_root + f, half_y + f, half_z + f), on_platform)
        return add_distance_refinement(faces, size, size_max, reach)
    return add_distance_refinement(root_edges(volume, on_root), size, size_max, reach, dim=1)


def split_blade(volume: int, x_split: float, x_tip: float, chord: float, thickness: float,
                stagger_deg: float) -> list[int]:
    """The blade of ``volume`` cut at x = ``x_split``: [the volume below, the blade box
    above up to ``x_tip``] (conformal at the cut, for :func:`mesh_in_layers`)."""
    from ._shapes import staggered_blade

    occ = gmsh.model.occ
    top = staggered_blade(x_split, x_tip, chord, thickness, stagger_deg)
    out, _ = occ.fragment([(3, volume)], [(3, top)])
    parts = sorted((t for d, t in out if d == 3), key=lambda t: occ.getCenterOfMass(3, t)[0])
    if len(parts) != 2:
        raise GeometryBuildError(f"the blade split into {len(parts)} volumes, expected 2")
    return parts


def mesh_in_layers(volume: int, layers: int, chord: float, thickness: float, n_c: int,
                   n_t: int) -> float:
    """Mesh a blade box (radial along x, a chord x thickness section) in ``layers`` prism
    layers along x, its section n_c x n_t cells cut into triangles (transfinite, the side
    faces recombined). Returns the section's cell size [m]."""
    faces = boundary_surfaces([(3, volume)])
    curves = {abs(t) for _, t in gmsh.model.getBoundary([(2, f) for f in faces],
                                                         combined=False, oriented=False)}
    for c in curves:
        a, b = (np.array(gmsh.model.getValue(0, t, [])) for _, t in
                gmsh.model.getBoundary([(1, c)], oriented=False))
        d = b - a
        length = float(np.linalg.norm(d))
        n = (layers if abs(d[0]) > 0.5 * length
             else n_c if length > 0.5 * (chord + thickness) else n_t)
        gmsh.model.mesh.setTransfiniteCurve(c, n + 1)
    for f in faces:
        gmsh.model.mesh.setTransfiniteSurface(f)
        if abs(gmsh.model.getNormal(f, [0.5, 0.5])[0]) < 0.5:  # a side face: quads
            gmsh.model.mesh.setRecombine(2, f)
    gmsh.model.mesh.setTransfiniteVolume(volume)
    return min(chord / n_c, thickness / n_t)


def root_edges(volume: int, on_root: Callable[[np.ndarray], bool]) -> list[int]:
    """The curves of ``volume``'s faces whose sampled points (k, 3) [m] all satisfy
    ``on_root``: where a blade's sides meet its platform (its root edges)."""
    curves = {abs(t) for _, t in gmsh.model.getBoundary(
        [(2, f) for f in boundary_surfaces([(3, volume)])], combined=False, oriented=False)}
    out = []
    for c in sorted(curves):
        lo, hi = gmsh.model.getParametrizationBounds(1, c)
        xyz = np.array(gmsh.model.getValue(1, c, np.linspace(lo[0], hi[0], 5).tolist()))
        if on_root(xyz.reshape(-1, 3)):
            out.append(c)
    if not out:
        raise GeometryBuildError("no blade root edge found on the platform")
    return out


def set_background_min(fields: list[int]) -> None:
    """Background mesh size = min of the given fields; no size from points/curvature."""
    f = gmsh.model.mesh.field
    if len(fields) == 1:
        f.setAsBackgroundMesh(fields[0])
    else:
        m = f.add("Min")
        f.setNumbers(m, "FieldsList", fields)
        f.setAsBackgroundMesh(m)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)


def box_field(size_in: float, size_out: float, lo, hi) -> int:
    """Size ``size_in`` inside the axis-aligned box [lo, hi], ``size_out`` outside."""
    f = gmsh.model.mesh.field
    b = f.add("Box")
    for key, val in zip(("XMin", "YMin", "ZMin"), lo, strict=True):
        f.setNumber(b, key, float(val))
    for key, val in zip(("XMax", "YMax", "ZMax"), hi, strict=True):
        f.setNumber(b, key, float(val))
    f.setNumber(b, "VIn", size_in)
    f.setNumber(b, "VOut", size_out)
    return b


def constant_field(size: float) -> int:
    """Uniform size field."""
    f = gmsh.model.mesh.field
    c = f.add("MathEval")
    f.setString(c, "F", repr(float(size)))
    return c


# ------------------------------------------------------------------ mesh extraction
class MeshReader:
    """Reads the current Gmsh mesh into 0-based arrays (nodes of its volume elements only:
    tetrahedra, and the prisms of a structured blade), and the curved edges of its
    second-order image: ``curved_edges`` (c, 2) sorted node pairs and ``edge_nodes`` (c, 3)
    their mid-edge points (m) where Gmsh places them on a curved geometry (arcs, cylinders)
    off the straight midpoint (tetrahedra's edges: a prism volume is straight-edged)."""

    def __init__(self) -> None:
        tags, coords, _ = gmsh.model.mesh.getNodes()
        coords = np.asarray(coords).reshape(-1, 3)
        tets_by_vol, prisms_by_vol = {}, {}
        used = []
        for _, vol in gmsh.model.getEntities(3):
            types, _, nodes = gmsh.model.mesh.getElements(3, vol)
            if list(types) not in ([4], [6]):
                raise GeometryBuildError(f"volume {vol}: elements {list(types)}, expected "
                                         "tetrahedra or prisms alone")
            corners = 4 if types[0] == 4 else 6
            t = np.asarray(nodes[0], dtype=np.int64).reshape(-1, corners)
            (tets_by_vol if corners == 4 else prisms_by_vol)[vol] = t
            used.append(t.ravel())
        used_tags = np.unique(np.concatenate(used))
        order = np.argsort(tags)
        sorted_tags = np.asarray(tags, dtype=np.int64)[order]
        pos = np.searchsorted(sorted_tags, used_tags)
        self.points = coords[order][pos]
        self._tags = used_tags  # sorted gmsh tags of used nodes; index = position
        self._tets_by_vol, self._prisms_by_vol = tets_by_vol, prisms_by_vol
        self.curved_edges, self.edge_nodes = self._curved_edges()

    def _curved_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Gmsh's mid-edge points of the second-order mesh (on the geometry), kept where off
        the straight midpoint; the mesh is returned to first order (setOrder renumbers the
        nodes, so the corners are matched element by element, not by tag)."""
        edges = _tet10_edges()
        pairs, mids = [], []
        gmsh.option.setNumber("Mesh.HighOrderOptimize", 2)  # untangle curved elements
        gmsh.model.mesh.setOrder(2)
        try:
            tags, coords, _ = gmsh.model.mesh.getNodes()
            order = np.argsort(tags)
            tags, coords = np.asarray(tags)[order], np.asarray(coords).reshape(-1, 3)[order]
            for vol, linear in self._tets_by_vol.items():
                types, _, nodes = gmsh.model.mesh.getElements(3, vol)
                quadratic = np.asarray(nodes[list(types).index(11)], np.int64).reshape(-1, 10)
                corners = self.index(linear.ravel()).reshape(-1, 4)
                pairs.append(np.sort(corners[:, edges].reshape(-1, 2), axis=1))
                mids.append(coords[np.searchsorted(tags, quadratic[:, 4:].ravel())])
        finally:
            gmsh.model.mesh.setOrder(1)
        if not pairs:
            return np.empty((0, 2), np.int64), np.empty((0, 3))
        pairs, first = np.unique(np.vstack(pairs), axis=0, return_index=True)
        xyz = np.vstack(mids)[first]
        a, b = self.points[pairs[:, 0]], self.points[pairs[:, 1]]
        off = (np.linalg.norm(xyz - 0.5 * (a + b), axis=1)
               > CURVED * np.linalg.norm(b - a, axis=1))
        return self._unfolded(pairs[off], xyz[off])

    def _unfolded(self, pairs: np.ndarray, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The curved edges less those of tetrahedra their mid nodes fold (a small element
        on a tight curve, as a blade root's fillet): those edges straight (their element
        maps; the geometry there within a fraction of the element's size)."""
        if not len(pairs) or not self._tets_by_vol:
            return pairs, xyz
        tets = self.index(np.concatenate(list(self._tets_by_vol.values())).ravel())
        tets = tets.reshape(-1, 4)
        edges = np.sort(tets[:, elements.EDGES["tetra"]], axis=2)  # (m, 6, 2)
        base = np.int64(len(self.points))
        keys = pairs[:, 0] * base + pairs[:, 1]
        for _ in range(3):  # straightening an edge can only unfold its neighbours
            mids = 0.5 * self.points[edges].sum(axis=2)
            where = np.searchsorted(keys, edges[..., 0] * base + edges[..., 1])
            where = np.minimum(where, len(keys) - 1)
            curved = keys[where] == edges[..., 0] * base + edges[..., 1]
            mids[curved] = xyz[where[curved]]
            bad = elements.folded_tets(self.points, tets, mids)
            if not bad.size:
                break
            drop = np.isin(keys, (edges[bad, :, 0] * base + edges[bad, :, 1]).ravel())
            pairs, xyz, keys = pairs[~drop], xyz[~drop], keys[~drop]
            if not len(pairs):
                break
        return pairs, xyz

    def index(self, gmsh_tags) -> np.ndarray:
        """0-based indices of Gmsh node tags (all must belong to tets)."""
        t = np.asarray(gmsh_tags, dtype=np.int64)
        idx = np.searchsorted(self._tags, t)
        if t.size and (np.any(idx >= len(self._tags)) or np.any(self._tags[idx] != t)):
            raise GeometryBuildError("a node of a named set belongs to no tetrahedron")
        return idx

    def wedges(self, volumes: list[int]) -> np.ndarray:
        """(m, 6) positively oriented wedges (prisms) of those of the given volumes that
        hold prisms (0-2 the bottom triangle, counter-clockwise seen from the top 3-5)."""
        parts = [self._prisms_by_vol[v] for v in volumes if v in self._prisms_by_vol]
        if not parts:
            return np.empty((0, 6), np.int64)
        w = self.index(np.concatenate(parts).ravel()).reshape(-1, 6)
        p = self.points[w]
        up = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]),
                       p[:, 3] - p[:, 0])
        w[up < 0] = w[up < 0][:, [0, 2, 1, 3, 5, 4]]
        return w

    def tets(self, volumes: list[int]) -> np.ndarray:
        """(m, 4) positively oriented tets of the given volumes (those that hold tets)."""
        volumes = [v for v in volumes if v in self._tets_by_vol]
        t = self.index(np.concatenate([self._tets_by_vol[v] for v in volumes]).ravel())
        t = t.reshape(-1, 4)
        p = self.points[t]
        d = p[:, 1:] - p[:, :1]
        neg = np.einsum("ij,ij->i", d[:, 0], np.cross(d[:, 1], d[:, 2])) < 0
        t[neg] = t[neg][:, [0, 2, 1, 3]]
        return t

    def surface_nodes(self, surfaces: list[int]) -> np.ndarray:
        """Sorted unique node indices on the surfaces (boundary curves included)."""
        out = [
            self.index(gmsh.model.mesh.getNodes(2, s, includeBoundary=True)[0]) for s in surfaces
        ]
        return np.unique(np.concatenate(out)) if out else np.zeros(0, np.int64)

    def point_node(self, point_tag: int) -> np.ndarray:
        """(1,) node index of a geometric point."""
        return self.index(gmsh.model.mesh.getNodes(0, point_tag)[0])


def _tet10_edges() -> np.ndarray:
    """(6, 2) corner pairs of Gmsh's 10-node tetrahedron's mid nodes, in its node order (read
    from its reference element, not assumed)."""
    ref = np.asarray(gmsh.model.mesh.getElementProperties(11)[4]).reshape(10, 3)
    half = 0.5 * (ref[:4, None] + ref[None, :4])  # (4, 4, 3) midpoints of corner pairs
    return np.array([np.argwhere(np.all(np.isclose(half, m), axis=2) & np.triu(
        np.ones((4, 4), bool), 1))[0] for m in ref[4:]])


def pair_cyclic(points: np.ndarray, left: np.ndarray, right: np.ndarray, sectors: int
                ) -> CyclicBoundary:
    """Pair left and right face nodes by the rotation 2 pi / Ns (checks a 1-1 match)."""
    if len(left) != len(right):
        raise GeometryBuildError(f"cyclic faces have {len(left)} vs {len(right)} nodes")
    image = points[left] @ rotation_z(2 * np.pi / sectors).T
    dist, j = cKDTree(points[right]).query(image)
    if dist.max(initial=0) > MATCH_TOL or len(np.unique(j)) != len(j):
        raise GeometryBuildError(f"cyclic faces do not match (max gap {dist.max():.3e} m)")
    return CyclicBoundary(left=left, right=right[j], sectors=sectors)


def grid_of_nodes(points: np.ndarray, nodes: np.ndarray, origin, e1, e2, n1: int, n2: int
                  ) -> np.ndarray:
    """Arrange the nodes of a structured rectangle into an (n1, n2) grid.

    origin: (3,) grid corner (m); e1, e2: (3,) edge vectors (m) spanning the rectangle;
    node (i, j) sits at origin + i/(n1-1) e1 + j/(n2-1) e2."""
    e1, e2, origin = (np.asarray(v, float) for v in (e1, e2, origin))
    rel = points[nodes] - origin
    s = rel @ e1 / (e1 @ e1) * (n1 - 1)
    t = rel @ e2 / (e2 @ e2) * (n2 - 1)
    i, j = np.rint(s).astype(np.int64), np.rint(t).astype(np.int64)
    # Off-grid residual: a transfinite grid on a flat rectangle is exactly uniform.
    off = max(np.abs(s - i).max(initial=0), np.abs(t - j).max(initial=0))
    grid = np.full((n1, n2), -1, dtype=np.int64)
    inside = (i >= 0) & (i < n1) & (j >= 0) & (j < n2)
    if len(nodes) != n1 * n2 or off > 1e-6 or not inside.all():
        raise GeometryBuildError(
            f"patch nodes are not an {n1} x {n2} grid ({len(nodes)} nodes, off-grid {off:.2e})"
        )
    grid[i, j] = nodes
    if np.any(grid < 0):
        raise GeometryBuildError("patch grid has holes (two nodes on one grid point)")
    return grid


def contact_patch(name: str, points: np.ndarray, body_a: str, nodes_a: np.ndarray,
                  body_b: str, nodes_b: np.ndarray, rect, n1: int, n2: int,
                  b_angle: float = 0.0, b_sector_offset: int = 0) -> ContactPatch:
    """ContactPatch from two node sets on one rectangle ``rect = (origin, e1, e2, normal)``
    given in body_a's (assembled) position; body_b's nodes are rotated by ``b_angle``."""
    origin, e1, e2, normal = rect
    ga = grid_of_nodes(points, nodes_a, origin, e1, e2, n1, n2)
    rot = rotation_z(-b_angle)  # bring the rectangle back onto body_b's own face
    gb = grid_of_nodes(points, nodes_b, rot @ origin, rot @ e1, rot @ e2, n1, n2)
    area = float(np.linalg.norm(np.cross(e1, e2)))
    return ContactPatch(name, body_a, body_b, ga, gb, normal, area, b_sector_offset)


def gmsh_min_sicn() -> float:
    """Gmsh's own minimum SICN over all tets of the current mesh (for the record)."""
    types, tags, _ = gmsh.model.mesh.getElements(3)
    if not len(tags):
        return float("nan")
    return float(np.min(gmsh.model.mesh.getElementQualities(tags[0], "minSICN")))
