"""A sector of a cyclic structure from any mesh: its axis, its two cyclic faces, their pairing.

The mesh contract puts the disk axis on +z through the origin and the fundamental sector
around +x (``geometry.mesh``). A mesh from another tool has its own axis (``axis`` through
``origin``); :func:`sector_frame` is the rigid motion into the contract's frame, which the
importer applies to the nodes (and records, so directions given in the file's frame follow).

Cyclic faces: given as two node sets per body, or found by geometry: the body's boundary
faces that lie on two planes through the axis ``phi = 2 pi / Ns`` apart. Faces whose nodes
match under the rotation are paired node to node; the right face's nodes are then placed on
the exact images of the left ones (they moved by less than the tolerance), so the pairing
holds to round-off downstream. Faces meshed independently are tied by interpolation
(``fe.cyclic``) when the finer one, turned onto the other, lies on it within the tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .boundaries import CyclicBoundary
from .mesh import Mesh, rotation_z
from .surfaces import project, surface_of


class SectorError(ValueError):
    """The cyclic faces cannot be found or do not match; one line naming the face."""


@dataclass(frozen=True)
class SectorSpec:
    """How an imported mesh is a sector.

    sectors: Ns >= 3; axis: (3,) the disk axis (any length, file frame); origin: (3,) a
    point of the axis [m]; faces: body -> (left set, right set) node-set names (the other
    bodies' faces are found by geometry); tolerance: the largest distance [m] between a
    node and its partner's image (and from a face's plane).
    """

    sectors: int
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    faces: tuple[tuple[str, str, str], ...] = ()  # (body, left set, right set)
    tolerance: float = 1e-6

    @property
    def angle(self) -> float:
        """phi = 2 pi / Ns (rad)."""
        return 2.0 * np.pi / self.sectors


def sector_frame(axis, origin) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), origin (3,)) with x' = R (x - origin) putting ``axis`` on +z (a rotation;
    the identity for an axis along +z)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(a, z), float(a @ z)
    if np.linalg.norm(v) < 1e-15:  # along +z or -z
        R = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:  # Rodrigues: the rotation by the angle between a and z about a x z
        vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        R = np.eye(3) + vx + vx @ vx / (1.0 + c)
    return R, np.asarray(origin, dtype=float)


def planar_faces(mesh: Mesh, body: str, angle: float, tol: float
                 ) -> tuple[np.ndarray, np.ndarray] | None:
    """(left nodes, right nodes) of ``body``: its boundary faces on two planes through the z
    axis ``angle`` apart (right = left rotated by +angle); None if it has no such pair.

    A facet is on a plane through the axis when its corners lie within ``tol`` of the plane
    at its centroid's angle; such facets are grouped into planes where their angles, in
    order round the axis, leave a gap wider than the nodes' scatter allows (tol / radius)."""
    tri = mesh.surface(body)
    p = mesh.points[tri]  # (t, 3, 3)
    radius = np.hypot(p[..., 0], p[..., 1])
    centre = p.mean(axis=1)
    theta_f = np.arctan2(centre[:, 1], centre[:, 0])
    theta = np.arctan2(p[..., 1], p[..., 0])
    off = np.abs(np.sin(theta - theta_f[:, None])) * radius  # distance to that plane
    # (a facet touching the axis, in a sector that contains it, lies on its plane too)
    reach = np.hypot(centre[:, 0], centre[:, 1])
    on_plane = np.flatnonzero((off.max(axis=1) <= tol) & (reach > tol))
    if not on_plane.size:
        return None
    spread = 4.0 * tol / reach[on_plane].min()  # the angular scatter of one plane's facets
    order = on_plane[np.argsort(theta_f[on_plane])]
    angles = theta_f[order]
    gaps = np.diff(np.concatenate([angles, angles[:1] + 2 * np.pi]))
    start = (int(np.argmax(gaps)) + 1) % len(order)  # begin after the widest gap
    order, angles = np.roll(order, -start), np.unwrap(np.roll(angles, -start))
    cuts = np.flatnonzero(np.diff(angles) > spread) + 1
    planes = [(float(np.mean(a)), o) for a, o in zip(np.split(angles, cuts),
                                                    np.split(order, cuts), strict=True)]
    best = None
    for a_left, left in planes:
        for a_right, right in planes:
            miss = abs(np.angle(np.exp(1j * (a_right - a_left - angle))))
            if miss <= spread and (best is None or len(left) + len(right) > best[0]):
                best = (len(left) + len(right), left, right)
    if best is None:
        return None
    return np.unique(tri[best[1]]), np.unique(tri[best[2]])


def paired(points: np.ndarray, left: np.ndarray, right: np.ndarray, angle: float,
           tol: float, face: str) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) node pairs with right[i] the image of left[i] by the rotation +angle
    about z; SectorError naming ``face`` and the worst distance when they do not match."""
    if len(left) != len(right):
        raise SectorError(f"{face}: the faces have {len(left)} and {len(right)} nodes")
    image = points[left] @ rotation_z(angle).T
    dist, nearest = cKDTree(points[right]).query(image)
    worst = float(dist.max(initial=0.0))
    if worst > tol or len(np.unique(nearest)) != len(right):
        raise SectorError(f"{face}: the right face is not the left one rotated by 2 pi / Ns "
                          f"(worst distance {worst:.3e} m, tolerance {tol:.3e} m)")
    return left, right[nearest]


def tied(mesh: Mesh, body: str, left: np.ndarray, right: np.ndarray, angle: float,
         tol: float, face: str) -> CyclicBoundary:
    """Faces that do not match node for node, tied by interpolation (``fe.cyclic``): the
    finer face's nodes, turned onto the other, must lie on it within ``tol`` (SectorError
    naming ``face`` and the worst distance otherwise)."""
    boundary = CyclicBoundary(left, right, round(2 * np.pi / angle), matching=False)
    slave, master = (right, left) if boundary.slave_is_right else (left, right)
    turn = rotation_z(-angle if boundary.slave_is_right else angle)
    on = project(mesh.points[slave] @ turn.T, mesh.points,
                 surface_of(mesh.body_cells(body), master))
    worst = float(on.gap.max(initial=0.0))
    if worst > tol:
        raise SectorError(f"{face}: the right face is not the left one rotated by 2 pi / Ns "
                          f"(worst distance {worst:.3e} m, tolerance {tol:.3e} m)")
    return boundary


def _boundary(mesh: Mesh, points: np.ndarray, body: str, faces, spec: SectorSpec,
              face: str) -> CyclicBoundary:
    """The first way ``faces`` ((left, right) candidates, in order) are cyclic faces: paired
    node for node (the right face then moved onto the exact images), or tied."""
    errors = []
    for left, right in faces:
        try:
            left, right = paired(points, left, right, spec.angle, spec.tolerance, face)
            points[right] = points[left] @ rotation_z(spec.angle).T
            return CyclicBoundary(left, right, spec.sectors)
        except SectorError as err:
            errors.append(err)
        try:
            return tied(mesh, body, left, right, spec.angle, spec.tolerance, face)
        except SectorError as err:
            errors.append(err)
    raise errors[-1 if len(faces) == 1 else 1]


def cyclic_boundaries(mesh: Mesh, spec: SectorSpec) -> tuple[np.ndarray, dict]:
    """(points with each matching right face on its left face's exact image, body ->
    CyclicBoundary) of a mesh already in the sector frame (axis +z through the origin)."""
    given = {body: (left, right) for body, left, right in spec.faces}
    unknown = sorted(set(given) - set(mesh.bodies))
    if unknown:
        raise SectorError(f"geometry.sector.faces: {unknown} are not bodies; bodies: "
                          f"{sorted(mesh.bodies)}")
    points = np.array(mesh.points)
    out = {}
    for body in mesh.bodies:
        if body in given:
            names = given[body]
            missing = [n for n in names if n not in mesh.node_sets]
            if missing:
                raise SectorError(f"geometry.sector.faces.{body} = {list(names)}: no node set "
                                  f"{missing[0]!r}; node sets: {sorted(mesh.node_sets)}")
            left, right = (mesh.node_sets[n] for n in names)
            faces = [(left, right), (right, left)]  # either order
            face = f"geometry.sector.faces.{body}"
        else:
            found = planar_faces(mesh, body, spec.angle, spec.tolerance)
            if found is None:
                continue  # not a cyclic body (a blade on its own, a damper)
            faces, face = [found], f"the cyclic faces of body {body!r}"
        out[body] = _boundary(mesh, points, body, faces, spec, face)
    return points, out


def centring(points: np.ndarray, boundaries: dict, angle: float) -> np.ndarray:
    """Rotation about z (3, 3) that puts the middle of the cyclic faces on +x (the contract's
    fundamental sector spans -phi/2 .. +phi/2); the identity without cyclic bodies."""
    if not boundaries:
        return np.eye(3)
    left = np.concatenate([b.left for b in boundaries.values()])
    p = points[left]
    theta = float(np.angle(np.exp(1j * np.arctan2(p[:, 1], p[:, 0])).mean()))
    return rotation_z(-(theta + 0.5 * angle))
