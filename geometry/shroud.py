"""Shrouded blisk sector: disk, blade and a tip shroud whose z-notch interlock touches the
neighbouring blade's shroud (Firrone & Zucca Fig. 1: the third friction source, beside
underplatform dampers and blade roots).

Geometry (fundamental sector, theta in [-phi/2, phi/2], blade along +x)
-----------------------------------------------------------------------
* Disk: annular sector r in [r_bore, r_rim], z in [-w/2, w/2] (planar cyclic faces).
* Blade: staggered prism (chord x thickness) from inside the rim to inside the shroud.
* Shroud: shroud_thickness thick radially above r_tip, z in [-shroud_width/2,
  shroud_width/2]; its inner and outer faces are planes normal to each gap's radial direction
  (a shallow roof over the blade), so that the interlock faces are rectangles; bounded
  tangentially at each blade gap (theta = +-phi/2) by the z-notch profile, in the
  gap's frame (rho radial, t tangential, z axial): the interlock face t = z tan(notch_angle)
  for |z| <= notch_length / 2, and the arms beyond it, parallel to z and held back by
  ``arm_clearance`` from the neighbour's. At zero interference the interlock faces of
  neighbouring shrouds coincide; the arms never touch. The interference (the preload of
  the interlock, what a turbine sets by twisting the shrouds at assembly) is the contact's
  ``interference`` in the case.

Body "blisk" (cyclic). Contact patch "shroud": body_a = body_b = "blisk", side a the
interlock face at theta = +phi/2, side b the sector's own interlock face at -phi/2 seen in
the next sector (b_sector_offset = +1: points[nodes_a] == R(phi) points[nodes_b]); normal
from side a into the neighbour. Grid index i runs radially across the shroud (n1 =
``contact_n_radial``), j along the interlock (n2 = ``contact_n_along``, +z).

Node sets: "blisk/bore", "blisk/shroud" (the shroud's outer face), "blisk/excitation" and
"blisk/response" (the blade's leading and trailing edges at mid-height), "cyclic/blisk/left",
"cyclic/blisk/right", "contact/shroud/a", "contact/shroud/b".
"""

from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np

from . import _gmsh as g
from ._shapes import blade_half_extent, local_to_xyz, radial_frame, staggered_blade
from .averaging import ContactGrids, face_nodes, patch_sets
from .mesh import Mesh
from .params import (
    GeometryBuildError,
    angle_deg,
    as_dict,
    check_ranges,
    contact_size_param,
    grid_count,
    param,
    positive_length,
    require,
)
from .simple import check_element_budget, cyclic_faces, revolve_sector


@dataclass(frozen=True)
class ShroudParameters:
    """Shrouded blisk sector; defaults: 36 steel blades, a 30 deg z-notch."""

    sectors: int = param(36, "-", 3, 400, "number of blades Ns", integer=True)
    r_bore: float = positive_length(0.10, "bore radius")
    r_rim: float = positive_length(0.20, "disk rim radius")
    width: float = positive_length(0.03, "axial width of the disk")
    blade_height: float = positive_length(0.08, "blade height from the rim to the shroud")
    blade_chord: float = positive_length(0.028, "blade chord")
    blade_thickness: float = positive_length(0.004, "blade thickness")
    blade_stagger: float = param(30.0, "deg", 0.0, 80.0, "chord angle to the axial direction")
    shroud_thickness: float = positive_length(0.004, "radial thickness of the shroud")
    shroud_width: float = positive_length(0.03, "axial width of the shroud")
    notch_angle: float = angle_deg(30.0, "interlock face angle to the axial direction")
    notch_length: float = positive_length(0.010, "axial length of the interlock face")
    arm_clearance: float = positive_length(0.0005, "tangential gap between the shroud arms")
    size: float = positive_length(0.008, "global tet size")
    blade_size: float = positive_length(0.004, "tet size in the blade and shroud")
    contact_n_radial: int = grid_count(3, "contact points across the shroud (n1)")
    contact_n_along: int = grid_count(6, "contact points along the interlock (n2)")
    contact_size: float = contact_size_param("interlock faces")

    @property
    def phi(self) -> float:
        return 2 * np.pi / self.sectors

    @property
    def r_tip(self) -> float:
        """Inner radius of the shroud (the blade's tip)."""
        return self.r_rim + self.blade_height

    @property
    def notch_t(self) -> float:
        """Tangential offset of the interlock's ends from the gap line (m)."""
        return 0.5 * self.notch_length * np.tan(np.radians(self.notch_angle))

    def validate(self) -> None:
        """Ranges, then the rules that make the geometry possible."""
        check_ranges(self)
        require(self.r_rim > self.r_bore, "r_rim", self.r_rim, f"> r_bore = {self.r_bore:g} m",
                "the disk needs radial depth")
        require(self.notch_length < self.shroud_width, "notch_length", self.notch_length,
                f"< shroud_width = {self.shroud_width:g} m", "the interlock needs arms")
        pitch = 2 * self.r_tip * np.sin(self.phi / 2)
        ty, tz = blade_half_extent(self.blade_chord, self.blade_thickness, self.blade_stagger)
        reach = self.notch_t + self.arm_clearance
        require(2 * (ty + reach) < pitch, "blade_chord", self.blade_chord,
                f"such that the blade ({2 * ty:.4g} m) and the notches ({2 * reach:.4g} m) "
                f"fit the pitch {pitch:.4g} m at the tip", "the shroud would cut the blade")
        require(2 * tz <= self.shroud_width, "blade_chord", self.blade_chord,
                f"such that the blade's axial extent {2 * tz:.4g} m <= shroud_width",
                "the blade would stick out of the shroud")
        require(self.arm_clearance < self.notch_t, "arm_clearance", self.arm_clearance,
                f"< {self.notch_t:.4g} m (the interlock's tangential reach)",
                "the arms would not clear the interlock")
        volume = np.pi * (self.r_rim**2 - self.r_bore**2) * self.width / self.sectors
        check_element_budget(volume, self.size)
        check_element_budget(4 * ty * tz * self.blade_height, self.blade_size, "blade_size")

    def interlock(self, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(origin, e1 radial, e2 along the interlock) of the interlock face at the gap
        ``theta`` (m): origin at (rho = r_tip, z = -notch_length / 2)."""
        a = 0.5 * self.notch_length
        origin = local_to_xyz(theta, self.r_tip, -self.notch_t, -a)
        e1 = self.shroud_thickness * radial_frame(theta)[0]
        e2 = local_to_xyz(theta, self.r_tip, self.notch_t, a) - origin
        return origin, e1, e2


def shrouded_blisk(params: ShroudParameters | None = None, **overrides) -> Mesh:
    """Mesh of the shrouded blisk sector (see the module doc); ``overrides`` replace fields.
    Raises GeometryParameterError before Gmsh runs, GeometryBuildError if Gmsh fails."""
    from dataclasses import replace

    p = replace(params or ShroudParameters(), **overrides)
    p.validate()
    return g.run_builder("shrouded_blisk", as_dict(p), lambda: _build(p))


def _notch_cut(p: ShroudParameters, theta: float, side: float) -> int:
    """The prism that removes what lies beyond the z-notch at the gap ``theta``: the
    neighbour's side (t > profile, ``side`` = +1) or the other (t < profile, -1), arms held
    back by the clearance, extruded radially through the shroud."""
    a, t0, c = 0.5 * p.notch_length, p.notch_t, p.arm_clearance
    far, z_far = side * 4 * (t0 + c + p.shroud_width), p.shroud_width
    profile = [(far, -z_far), (-t0 - side * c, -z_far), (-t0 - side * c, -a), (-t0, -a),
               (t0, a), (t0 - side * c, a), (t0 - side * c, z_far), (far, z_far)]
    rho0 = p.r_tip - p.shroud_thickness
    occ = gmsh.model.occ
    pts = [occ.addPoint(*map(float, local_to_xyz(theta, rho0, t, z))) for t, z in profile]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    step = 3 * p.shroud_thickness * radial_frame(theta)[0]
    out = occ.extrude([(2, face)], *map(float, step))
    return next(t for d, t in out if d == 3)


def _roof(p: ShroudParameters) -> int:
    """The shroud before its notches: a slab whose inner and outer faces are planes normal
    to each gap's radial direction (so the interlock faces, cut across them, are rectangles
    and each is the image of the other), meeting over the blade."""
    half = p.phi / 2
    reach = 2.0 * (p.notch_t + p.arm_clearance)
    corners = []
    for rho in (p.r_tip, p.r_tip + p.shroud_thickness):
        ridge = np.array([rho / np.cos(half), 0.0, -p.shroud_width / 2])
        right = local_to_xyz(half, rho, reach, -p.shroud_width / 2)
        left = local_to_xyz(-half, rho, -reach, -p.shroud_width / 2)
        corners.append([right, ridge, left] if rho == p.r_tip else [left, ridge, right])
    occ = gmsh.model.occ
    pts = [occ.addPoint(*map(float, c)) for c in corners[0] + corners[1]]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    out = occ.extrude([(2, face)], 0.0, 0.0, p.shroud_width)
    return next(t for d, t in out if d == 3)


def _build(p: ShroudParameters) -> Mesh:
    occ = gmsh.model.occ
    phi = p.phi
    disk = revolve_sector(p.r_bore, p.r_rim, -p.width / 2, p.width / 2, p.sectors)
    slab = _roof(p)
    shroud, _ = occ.cut([(3, slab)], [(3, _notch_cut(p, phi / 2, 1.0)),
                                      (3, _notch_cut(p, -phi / 2, -1.0))])
    blade = staggered_blade(p.r_rim - p.blade_thickness, p.r_tip + 0.5 * p.shroud_thickness,
                            p.blade_chord, p.blade_thickness, p.blade_stagger)
    fused, _ = occ.fuse([(3, disk)], [*shroud, (3, blade)])
    if len(fused) != 1:
        raise GeometryBuildError(f"the shrouded blisk is not one solid: {fused}")
    blisk = fused[0][1]
    occ.synchronize()
    return _mesh_and_read(p, blisk)


def _mesh_and_read(p: ShroudParameters, blisk: int) -> Mesh:
    occ = gmsh.model.occ
    left, right = cyclic_faces([blisk], p.sectors)
    g.set_periodic_rotation(left, right, p.phi)
    faces = g.boundary_surfaces([(3, blisk)])
    rect_a, rect_b = p.interlock(p.phi / 2), p.interlock(-p.phi / 2)
    patch = []
    for origin, e1, e2 in (rect_a, rect_b):
        area = float(np.linalg.norm(np.cross(e1, e2)))
        face = g.surface_with_centre(faces, origin + 0.5 * (e1 + e2), area)
        g.set_transfinite_rectangle(face, e1, *face_nodes(
            p.contact_n_radial, p.contact_n_along, e1, e2, p.contact_size))
        patch.append(face)
    ty, tz = blade_half_extent(p.blade_chord, p.blade_thickness, p.blade_stagger)
    fields = [g.constant_field(p.size),
              g.box_field(p.blade_size, p.size, (p.r_rim - p.width / 10, -p.r_tip, -p.width),
                          (p.r_tip + 2 * p.shroud_thickness, p.r_tip, p.width))]
    if p.contact_size > 0.0:  # grade the finer interlock mesh into the shroud's
        fields.append(g.add_distance_refinement(patch, min(p.contact_size, p.blade_size),
                                                p.size, 3 * p.shroud_thickness))
    g.set_background_min(fields)
    gmsh.model.addPhysicalGroup(3, [blisk], name="blisk")
    gmsh.model.mesh.generate(3)
    r = g.MeshReader()
    tets = r.tets([blisk])
    left_n, right_n = r.surface_nodes(left), r.surface_nodes(right)
    bore = [f for f in faces if g.on_cylinder(f, p.r_bore)]
    outer = [f for theta in (p.phi / 2, -p.phi / 2) for f in g.surfaces_on_plane(
        faces, (p.r_tip + p.shroud_thickness) * radial_frame(theta)[0], radial_frame(theta)[0])]
    mid = p.r_rim + 0.5 * p.blade_height
    edges = _blade_edges(r.points, np.unique(tets), mid, tz)
    origin, e1, e2 = rect_a
    normal = np.cross(e1, e2)
    normal /= np.linalg.norm(normal)
    if normal @ radial_frame(p.phi / 2)[1] < 0:  # from side a into the neighbour (+t)
        normal = -normal
    grids = ContactGrids(r.points, p.contact_size)
    contact = grids.patch("shroud", ("blisk", {"tetra": tets}, r.surface_nodes([patch[0]])),
                          ("blisk", {"tetra": tets}, r.surface_nodes([patch[1]])),
                          (origin, e1, e2, normal), p.contact_n_radial, p.contact_n_along,
                          b_angle=p.phi, b_sector_offset=1)
    na, nb = patch_sets(contact)
    return Mesh(
        model="shrouded_blisk",
        **grids.mesh_fields(),
        curved_edges=r.curved_edges,
        edge_nodes=r.edge_nodes,
        tetrahedra=tets,
        bodies={"blisk": np.arange(len(tets))},
        node_sets={"blisk/bore": r.surface_nodes(bore), "blisk/shroud": r.surface_nodes(outer),
                   "blisk/excitation": edges[:1], "blisk/response": edges[1:2],
                   "cyclic/blisk/left": left_n, "cyclic/blisk/right": right_n,
                   "contact/shroud/a": na, "contact/shroud/b": nb},
        cyclic={"blisk": g.pair_cyclic(r.points, left_n, right_n, p.sectors)},
        contacts={"shroud": contact},
        parameters={**as_dict(p), "derived": {"sector_angle": p.phi,
                                              "cad_volume": {"blisk": occ.getMass(3, blisk)},
                                              "gmsh_min_sicn": g.gmsh_min_sicn()}},
    )


def _blade_edges(points: np.ndarray, nodes: np.ndarray, radius: float, tz: float
                 ) -> np.ndarray:
    """(2,) the blade's nodes nearest its leading (min z) and trailing (max z) corners at
    ``radius``, in that order: the excitation and response points."""
    near = nodes[np.abs(points[nodes, 0] - radius) < 0.02 * radius]
    lead = near[np.argmin(points[near, 2])]
    trail = near[np.argmax(points[near, 2])]
    if points[lead, 2] > -0.5 * tz or points[trail, 2] < 0.5 * tz:
        raise GeometryBuildError("no blade edge node near mid-height")
    return np.array([lead, trail], dtype=np.int64)
