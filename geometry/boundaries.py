"""What a mesh names beside its elements: a sector body's cyclic faces
(:class:`CyclicBoundary`), contact pairs of three kinds (:class:`ContactPatch`, matching
structured grids; :class:`SurfaceContact`, named surfaces paired node by node;
:class:`AveragedContact`, contact points averaging cells of a finer surface mesh) and
supports (:class:`Support`: nodes held in some directions of a frame), each validated on
creation (:class:`MeshValidationError`)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np


class MeshValidationError(ValueError):
    """A :class:`Mesh` (or one of its parts) violates the mesh contract."""


def index_array(name: str, values, ndim: int | None = None) -> np.ndarray:
    arr = np.asarray(values)
    if arr.size == 0:
        arr = arr.astype(np.int64)
    if not np.issubdtype(arr.dtype, np.integer):
        raise MeshValidationError(f"{name}: expected integer indices, got dtype {arr.dtype}")
    if ndim is not None and arr.ndim != ndim:
        raise MeshValidationError(f"{name}: expected {ndim}-D array, got shape {arr.shape}")
    return frozen(arr.astype(np.int64))


def frozen(arr: np.ndarray) -> np.ndarray:
    out = np.ascontiguousarray(arr).copy()
    out.setflags(write=False)
    return out


def own_images_only(left: np.ndarray, right: np.ndarray, matching: bool) -> bool:
    """Whether every node on both cyclic faces is paired with itself (``left[i] ==
    right[i]``: a node on the axis, of a sector that contains it; matching faces only)."""
    both = np.intersect1d(left, right)
    if not both.size:
        return True
    return bool(matching and len(left) == len(right)
                and np.array_equal(np.unique(left[left == right]), both))


@dataclass(frozen=True)
class CyclicBoundary:
    """The periodic faces of one sector body.

    left:    (k,) int64 node indices on the left cyclic face (theta = -phi/2)
    right:   (k,) int64; ``right[i]`` is the image of ``left[i]`` under the rotation
             by +phi about +z
    sectors: Ns; ``phi = 2 pi / Ns``
    matching: False for faces meshed independently: ``left`` (k,) and ``right`` (k',) are
             then just each face's nodes, and the finer face follows the other by
             interpolation (``fe.cyclic``); the image of one face lies on the other
    A sector that contains the axis has its axis nodes on both faces, each its own image
    (``left[i] == right[i]``; matching faces only).
    """

    left: np.ndarray
    right: np.ndarray
    sectors: int
    matching: bool = True

    def __post_init__(self) -> None:
        left = index_array("CyclicBoundary.left", self.left, 1)
        right = index_array("CyclicBoundary.right", self.right, 1)
        if self.matching and left.shape != right.shape:
            raise MeshValidationError(
                f"CyclicBoundary: left {left.shape} and right {right.shape} differ in size"
            )
        if int(self.sectors) < 3:
            raise MeshValidationError(f"CyclicBoundary.sectors = {self.sectors}, must be >= 3")
        if not own_images_only(left, right, self.matching):
            raise MeshValidationError("CyclicBoundary: a node is on both left and right faces "
                                      "but not its own image (only a node on the axis is)")
        object.__setattr__(self, "left", left)
        object.__setattr__(self, "right", right)
        object.__setattr__(self, "sectors", int(self.sectors))

    @property
    def angle(self) -> float:
        """Sector angle phi = 2 pi / Ns (rad)."""
        return 2.0 * np.pi / self.sectors

    @property
    def slave_is_right(self) -> bool:
        """Whether the right face follows the left (the rule of matching faces, and of
        non-matching ones where the right face is the finer), else the left the right."""
        return len(self.right) >= len(self.left)


@dataclass(frozen=True)
class ContactPatch:
    """Two touching faces meshed as the same structured n1 x n2 grid.

    name:    patch name (also used in node-set names "contact/<name>/<body>")
    body_a:  body owning ``nodes_a``; it may be ``body_b`` when the touching face is a
             neighbouring sector's (a shroud touching the next blade's)
    body_b:  body owning ``nodes_b``
    nodes_a: (n1, n2) int64 node indices on body_a's face; ``nodes_a[i, j]`` and
             ``nodes_a[i+1, j]`` are neighbours along the patch's first direction
    nodes_b: (n1, n2) int64 node indices on body_b's face, paired with nodes_a
    normal:  (3,) unit outward normal of body_a's face (from body_a into body_b), in
             the assembled position of body_a (body_a is never rotated)
    area:    patch area (m^2)
    b_sector_offset:
             k, an integer. The face of body_b that touches may belong to a neighbouring
             sector of a cyclic body (the blisk damper touches the platform of the next
             blade). Then ``nodes_b`` are the *fundamental sector's own* nodes and the
             touching face is their image under the rotation by ``k phi`` about +z:
             ``points[nodes_a] == points[nodes_b] @ R(k phi).T`` (within 1e-9 m).
             Downstream, the displacement of the touching face at nodal diameter h is
             ``exp(i h k phi) R(k phi) u_b`` (per temporal harmonic n: h = n EO).
             ``k = 0`` (default): plain coincidence, ``points[nodes_a] == points[nodes_b]``.
    """

    name: str
    body_a: str
    body_b: str
    nodes_a: np.ndarray
    nodes_b: np.ndarray
    normal: np.ndarray
    area: float
    b_sector_offset: int = 0

    def __post_init__(self) -> None:
        nodes_a = index_array(f"ContactPatch {self.name!r}.nodes_a", self.nodes_a, 2)
        nodes_b = index_array(f"ContactPatch {self.name!r}.nodes_b", self.nodes_b, 2)
        if nodes_a.shape != nodes_b.shape:
            raise MeshValidationError(
                f"ContactPatch {self.name!r}: nodes_a {nodes_a.shape} != nodes_b {nodes_b.shape}"
            )
        if min(nodes_a.shape) < 2:
            raise MeshValidationError(
                f"ContactPatch {self.name!r}: grid {nodes_a.shape} is smaller than 2 x 2"
            )
        normal = np.asarray(self.normal, dtype=np.float64)
        if normal.shape != (3,) or abs(np.linalg.norm(normal) - 1.0) > 1e-9:
            raise MeshValidationError(
                f"ContactPatch {self.name!r}: normal must be a (3,) unit vector, got {normal}"
            )
        if not float(self.area) > 0.0:
            raise MeshValidationError(f"ContactPatch {self.name!r}: area {self.area} <= 0")
        if (self.body_a == self.body_b and not self.b_sector_offset
                and np.intersect1d(nodes_a, nodes_b).size):
            raise MeshValidationError(
                f"ContactPatch {self.name!r}: body_a == body_b on shared nodes (a body "
                "touches itself in a neighbouring sector, b_sector_offset, or elsewhere on "
                "nodes of its own: a full disk's interlocks)")
        object.__setattr__(self, "nodes_a", nodes_a)
        object.__setattr__(self, "nodes_b", nodes_b)
        object.__setattr__(self, "normal", frozen(normal))
        object.__setattr__(self, "area", float(self.area))
        object.__setattr__(self, "b_sector_offset", int(self.b_sector_offset))

    @property
    def shape(self) -> tuple[int, int]:
        """Grid shape (n1, n2)."""
        return tuple(self.nodes_a.shape)


@dataclass(frozen=True)
class SurfaceContact:
    """A contact between two named surfaces of any meshes (``geometry.pairing`` pairs them
    node to surface when it is needed), or between one surface and the ground.

    name:    contact name
    body_a:  body owning the surface ``set_a`` (side a: the finer of the two; its nodes
             are the contact points)
    set_a:   node-set name; the body's boundary faces whose nodes all lie in it
    body_b:  body owning ``set_b``; None: the ground (rigid, fixed)
    set_b:   node-set name of side b (None with the ground)
    b_sector_offset:
             k: side b is the image of ``set_b`` in the sector k sectors on (a
             neighbouring sector's face, as for :class:`ContactPatch`); 0: none
    tolerance:
             [m] how far outside side b a node of side a may project and still be
             paired (nodes farther out, with less than half their area over side b,
             touch nothing and are left out)
    spread:  how the contact's stiffness is shared among its pairs: "area", by their
             tributary areas; "nodes", equally (Firrone & Zucca's choice, which a
             structured patch makes)
    """

    name: str
    body_a: str
    set_a: str
    body_b: str | None = None
    set_b: str | None = None
    b_sector_offset: int = 0
    tolerance: float = 0.0
    spread: str = "area"

    def __post_init__(self) -> None:
        if self.spread not in ("area", "nodes"):
            raise MeshValidationError(f"SurfaceContact {self.name!r}: spread = "
                                      f"{self.spread!r}, expected 'area' or 'nodes'")
        if (self.body_b is None) != (self.set_b is None):
            raise MeshValidationError(f"SurfaceContact {self.name!r}: body_b and set_b go "
                                      "together (both None: the ground)")
        if self.body_b is None and self.b_sector_offset:
            raise MeshValidationError(f"SurfaceContact {self.name!r}: the ground has no "
                                      "neighbouring sector")
        if self.body_a == self.body_b and not self.b_sector_offset:
            raise MeshValidationError(
                f"SurfaceContact {self.name!r}: body_a == body_b (a body touches itself only "
                "in a neighbouring sector: b_sector_offset)")
        if not float(self.tolerance) >= 0.0:
            raise MeshValidationError(f"SurfaceContact {self.name!r}: tolerance "
                                      f"{self.tolerance} < 0")
        object.__setattr__(self, "b_sector_offset", int(self.b_sector_offset))
        object.__setattr__(self, "tolerance", float(self.tolerance))


@dataclass(frozen=True)
class AveragedContact:
    """A contact between named surfaces whose points stand for patches of them, about
    ``spacing`` apart (``geometry.averaging.averaged_surfaces``): the contact grid apart from
    an imported mesh. Each point of side a and its partner on side b are averaged points of
    the mesh (``Mesh.averages``) over the same part of the surfaces.

    name; body_a; body_b (None: the ground); nodes_a: (k,) side a's points; nodes_b: (k,)
    their partners on body b (empty with the ground); normals: (k, 3) unit normals from body
    a into body b; areas: (k,) [m^2] the areas the points stand for; gaps: (k,) [m] normal
    gaps (positive: open); faces: (F, 4) int64 side a's touching facets, mesh nodes (a
    triangle's 4th -1): the map's cells; owner: (m,) the point each of their nodes (sorted)
    stands in; b_sector_offset, spread: as :class:`SurfaceContact`'s; spacing: [m] the
    points' spacing asked for; set_a, set_b: the named surfaces it joins; dropped: side a's
    nodes left out, touching nothing (their count); reach: [m] how far beyond side b the
    farthest of them projects.
    """

    name: str
    body_a: str
    body_b: str | None
    nodes_a: np.ndarray
    nodes_b: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    gaps: np.ndarray
    faces: np.ndarray
    owner: np.ndarray
    b_sector_offset: int = 0
    spread: str = "area"
    spacing: float = 0.0
    set_a: str = ""
    set_b: str = ""
    dropped: int = 0
    reach: float = 0.0

    def __post_init__(self) -> None:
        pre = f"AveragedContact {self.name!r}"
        nodes_a = index_array(f"{pre}: nodes_a", self.nodes_a, 1)
        nodes_b = index_array(f"{pre}: nodes_b", self.nodes_b, 1)
        k = len(nodes_a)
        if k == 0 or len(nodes_b) not in ((0,) if self.body_b is None else (k,)):
            raise MeshValidationError(f"{pre}: {k} points on side a and {len(nodes_b)} on "
                                      "side b (one partner each, none with the ground)")
        normals = np.asarray(self.normals, dtype=np.float64).reshape(-1, 3)
        areas = np.asarray(self.areas, dtype=np.float64).reshape(-1)
        gaps = np.asarray(self.gaps, dtype=np.float64).reshape(-1)
        if len(normals) != k or len(areas) != k or len(gaps) != k:
            raise MeshValidationError(f"{pre}: normals, areas and gaps need one row per "
                                      f"point ({k})")
        if not (np.all(areas > 0) and np.allclose(np.linalg.norm(normals, axis=1), 1.0)):
            raise MeshValidationError(f"{pre}: every area must be > 0 and every normal a "
                                      "unit vector")
        faces = index_array(f"{pre}: faces", np.asarray(self.faces) + 1, 2).reshape(-1, 4) - 1
        owner = index_array(f"{pre}: owner", self.owner, 1)
        if len(faces) == 0 or np.any(faces[:, :3] < 0):
            raise MeshValidationError(f"{pre}: faces must be side a's facets, mesh nodes (-1 "
                                      "only as a triangle's 4th corner)")
        if len(owner) != len(np.unique(faces[faces >= 0])) or owner.max() >= k:
            raise MeshValidationError(f"{pre}: owner needs one point (< {k}) per node of the "
                                      "faces")
        if self.spread not in ("area", "nodes"):
            raise MeshValidationError(f"{pre}: spread = {self.spread!r}, expected 'area' or "
                                      "'nodes'")
        for name, value in (("nodes_a", nodes_a), ("nodes_b", nodes_b), ("normals", normals),
                            ("areas", areas), ("gaps", gaps), ("faces", faces),
                            ("owner", owner)):
            object.__setattr__(self, name, frozen(value))
        object.__setattr__(self, "b_sector_offset", int(self.b_sector_offset))
        object.__setattr__(self, "spacing", float(self.spacing))
        object.__setattr__(self, "dropped", int(self.dropped))
        object.__setattr__(self, "reach", float(self.reach))


#: The frames a support's directions are given in, with the names of their directions
FRAMES = {"global": ("x", "y", "z"), "rectangular": ("x", "y", "z"),
          "cylindrical": ("r", "theta", "z")}


@dataclass(frozen=True)
class Support:
    """Nodes of one body held (zero displacement) in some directions of a frame: a deck's
    ``*BOUNDARY`` or a case's support.

    nodes: (k,) int64 node indices; held: (3,) bool, which of the frame's three directions
    are held; frame: "global" (x, y, z), "rectangular" (the rows of ``axes`` (3, 3): the
    local x, y, z unit vectors) or "cylindrical" (local r, theta, z about the axis through
    ``origin`` (3,) [m] along ``axes[2]``; theta = z x r).
    """

    nodes: np.ndarray
    held: np.ndarray
    frame: str = "global"
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        nodes = np.unique(index_array("Support.nodes", self.nodes, 1))
        held = np.asarray(self.held, dtype=bool).reshape(-1)
        if held.shape != (3,) or not held.any():
            raise MeshValidationError(f"Support.held = {held.tolist()}: three flags, one "
                                      "at least set")
        if self.frame not in FRAMES:
            raise MeshValidationError(f"Support.frame = {self.frame!r}: expected one of "
                                      f"{sorted(FRAMES)}")
        axes = np.asarray(self.axes, dtype=np.float64).reshape(3, 3)
        if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-9):
            raise MeshValidationError("Support.axes: rows must be orthonormal unit vectors")
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "held", frozen(held))
        object.__setattr__(self, "axes", frozen(axes))
        object.__setattr__(self, "origin", frozen(np.asarray(self.origin, float).reshape(3)))

    def held_directions(self, xyz: np.ndarray) -> np.ndarray:
        """(k, m, 3) the unit vectors held at points ``xyz`` (k, 3) [m] (m held directions);
        ValueError for a point on a cylindrical frame's axis (no radial direction there)."""
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        if self.frame != "cylindrical":
            return np.broadcast_to(self.axes[self.held], (len(xyz), int(self.held.sum()), 3))
        axis = self.axes[2]
        d = xyz - self.origin
        radial = d - np.outer(d @ axis, axis)
        r = np.linalg.norm(radial, axis=1)
        if np.any(r <= 1e-12 * max(1.0, float(np.abs(d).max(initial=0.0)))):
            raise ValueError("a support in a cylindrical frame holds a node on its axis, "
                             "where the radial direction is undefined")
        radial = radial / r[:, None]
        frames = np.stack([radial, np.cross(axis, radial), np.broadcast_to(axis, xyz.shape)],
                          axis=1)
        return frames[:, self.held]

    @property
    def digest(self) -> str:
        """sha256 hex digest of what the support holds: its nodes, directions and frame."""
        h = hashlib.sha256(self.frame.encode())
        for a in (self.nodes, self.held.astype(np.int8), self.axes, self.origin):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()

    def moved(self, rotation: np.ndarray, shift: np.ndarray) -> Support:
        """The support after the mesh moved by x -> rotation x + shift."""
        rotation = np.asarray(rotation)
        return Support(self.nodes, self.held, self.frame, self.axes @ rotation.T,
                       rotation @ self.origin + np.asarray(shift))

    def describe(self) -> str:
        """"held in x, z" / "held in r (cylindrical about (0, 0, 1))"."""
        names = [n for n, h in zip(FRAMES[self.frame], self.held, strict=True) if h]
        where = {"global": "", "rectangular": " of a local frame",
                 "cylindrical": f" (cylindrical about {np.round(self.axes[2], 4).tolist()})"}
        return f"{len(self.nodes)} nodes held in {', '.join(names)}{where[self.frame]}"
