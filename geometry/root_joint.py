"""Disk sector with an axial dovetail slot and a blade with its dovetail root (Firrone &
Zucca 5.3.1, Fig. 19): two bodies touching on the two root flanks.

Geometry (fundamental sector, theta in [-phi/2, phi/2], blade along +x)
-----------------------------------------------------------------------
* Disk: annular sector r in [r_bore, r_rim], z in [-w/2, w/2], with an axial slot
  through the full width centred on theta = 0. Slot section (local frame: rho along +x,
  t along +y): a neck ``neck_width`` wide from the rim down to rho = r_neck =
  r_rim - neck_depth, then two flanks inclined at ``flank_angle`` to the radial direction
  (widening inwards) over the radial height ``flank_height``, then a flat bottom.
* Blade: the dovetail root is the slot section shrunk by ``clearance`` everywhere except
  on the flanks: its flanks lie on the slot flanks between rho = r_neck - clearance and
  r_flank_bottom + clearance (zero interference, Firrone & Zucca: Delta = 0); neck/shank up to
  r_rim + shank_height, a flat platform (``platform_thickness``, tangential width = pitch
  at r_rim minus ``platform_gap``), then a straight staggered airfoil prism.

Bodies
------
"disk" (cyclic: ``mesh.cyclic["disk"]``) and "blade" (free-free).

Contact patches (body_a = "blade", body_b = "disk", b_sector_offset = 0)
------------------------------------------------------------------------
"root_left"  root flank at t < 0;  "root_right"  root flank at t > 0.
normal = outward normal of the root flank (blade -> disk; it points outwards in rho, so
centrifugal load closes the contact). Grid index i runs axially (+z, n1 =
``contact_n_axial``), j along the flank from its inner (bottom) edge outwards (n2 =
``contact_n_flank``). points[nodes_a] == points[nodes_b].

Node sets
---------
"disk/bore"                             nodes on r = r_bore
"cyclic/disk/left", "cyclic/disk/right" cyclic faces (pairing in ``cyclic``)
"blade/tip"                             nodes of the blade tip face
"blade/excitation"                      (1,) tip corner with the smallest z
"blade/response"                        (1,) tip corner with the largest z
"contact/root_left/blade", "contact/root_left/disk",
"contact/root_right/blade", "contact/root_right/disk"
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import gmsh
import numpy as np

from . import _gmsh as g
from ._shapes import (
    axial_prism,
    blade_cells,
    blade_half_extent,
    local_to_xyz,
    rectangle_face,
    staggered_blade,
)
from .averaging import ContactGrids, face_nodes, patch_sets
from .mesh import Mesh
from .params import (
    GeometryBuildError,
    angle_deg,
    as_dict,
    blade_layers_param,
    check_ranges,
    contact_size_param,
    grid_count,
    param,
    positive_length,
    require,
    root_fillet_param,
    root_size_param,
)
from .simple import check_element_budget, cyclic_faces, revolve_sector


@dataclass(frozen=True)
class RootJointParameters:
    """Mock bladed disk with dovetail roots; defaults: 12 steel blades."""

    sectors: int = param(12, "-", 3, 400, "number of blades Ns", integer=True)
    r_bore: float = positive_length(0.05, "bore radius")
    r_rim: float = positive_length(0.15, "disk rim radius")
    width: float = positive_length(0.03, "axial width of disk, slot and root")
    neck_width: float = positive_length(0.012, "tangential width of the slot neck")
    neck_depth: float = positive_length(0.004, "radial depth from the rim to the flanks")
    flank_height: float = positive_length(0.01, "radial height of the slot flanks")
    flank_angle: float = angle_deg(55.0, "flank angle to the radial direction")
    clearance: float = positive_length(0.0005, "root-slot gap off the flanks")
    shank_height: float = positive_length(0.006, "root neck height above the rim")
    platform_thickness: float = positive_length(0.004, "blade platform thickness")
    platform_gap: float = positive_length(0.002, "tangential gap between platforms")
    blade_height: float = positive_length(0.1, "airfoil height above the platform")
    blade_chord: float = positive_length(0.028, "airfoil chord")
    blade_thickness: float = positive_length(0.005, "airfoil thickness")
    blade_stagger: float = param(30.0, "deg", 0.0, 80.0, "chord angle to the axial direction")
    size: float = positive_length(0.01, "global tet size")
    blade_size: float = positive_length(0.004, "tet size in the blade")
    contact_n_axial: int = grid_count(9, "contact points along the axis (n1)")
    contact_n_flank: int = grid_count(4, "contact points along the flank (n2)")
    contact_size: float = contact_size_param()
    root_fillet: float = root_fillet_param("airfoil")
    root_size: float = root_size_param("airfoil")
    blade_layers: int = blade_layers_param("airfoil")

    @property
    def phi(self) -> float:
        return 2 * np.pi / self.sectors

    @property
    def r_neck(self) -> float:
        """rho where the slot neck meets the flanks."""
        return self.r_rim - self.neck_depth

    @property
    def r_flank_bottom(self) -> float:
        return self.r_neck - self.flank_height

    @property
    def r_platform(self) -> float:
        """rho of the platform underside."""
        return self.r_rim + self.shank_height

    @property
    def r_tip(self) -> float:
        return self.r_platform + self.platform_thickness + self.blade_height

    def flank_t(self, rho: float) -> float:
        """Half-width of the slot at rho on the flanks (m)."""
        return self.neck_width / 2 + (self.r_neck - rho) * np.tan(np.radians(self.flank_angle))

    @property
    def x_platform_top(self) -> float:
        """x [m] of the platform's top face (the airfoil's root)."""
        return self.r_platform + self.platform_thickness

    @property
    def blade_split(self) -> float:
        """x [m] where a prism-layered airfoil (``blade_layers``) starts: a quarter of its
        thickness above the platform (the root below meshed with it)."""
        return self.x_platform_top + 0.25 * self.blade_thickness + self.root_fillet

    @property
    def platform_half_width(self) -> float:
        return self.r_rim * np.sin(self.phi / 2) - self.platform_gap / 2

    def validate(self) -> None:
        """Ranges of every field, then the rules that make the geometry possible."""
        check_ranges(self)
        require(self.r_rim > self.r_bore, "r_rim", self.r_rim, f"> r_bore = {self.r_bore:g} m",
                "the disk needs radial depth")
        floor = self.r_bore + 0.2 * (self.r_rim - self.r_bore)
        require(self.r_flank_bottom >= floor, "flank_height", self.flank_height,
                f"such that the slot bottom {self.r_flank_bottom:.4g} m >= {floor:.4g} m",
                "the slot may use at most 80 % of the disk's radial depth")
        pitch = 2 * self.r_flank_bottom * np.sin(self.phi / 2)
        require(2 * self.flank_t(self.r_flank_bottom) <= 0.8 * pitch, "flank_height",
                self.flank_height,
                f"such that the slot bottom width {2 * self.flank_t(self.r_flank_bottom):.4g} m"
                f" <= 80 % of the pitch {pitch:.4g} m there", "the slot would cut the sector")
        require(self.clearance < self.flank_height / 3, "clearance", self.clearance,
                f"< flank_height / 3 = {self.flank_height / 3:.4g} m",
                "the root flank would vanish")
        require(self.clearance < self.neck_width / 4, "clearance", self.clearance,
                f"< neck_width / 4 = {self.neck_width / 4:.4g} m", "the root neck would vanish")
        require(self.clearance < self.neck_depth, "clearance", self.clearance,
                f"< neck_depth = {self.neck_depth:g} m", "the root flank must start in the slot")
        pitch_rim = 2 * self.r_rim * np.sin(self.phi / 2)
        require(self.platform_gap < 0.5 * pitch_rim, "platform_gap", self.platform_gap,
                f"< {0.5 * pitch_rim:.4g} m (half the pitch at the rim)", "platforms must exist")
        require(self.platform_half_width > self.neck_width / 2, "platform_gap",
                self.platform_gap, "small enough for the platform to cover the root neck",
                "the platform must sit on the root neck")
        ty, tz = blade_half_extent(self.blade_chord, self.blade_thickness, self.blade_stagger)
        require(ty < self.platform_half_width, "blade_chord", self.blade_chord,
                f"such that the staggered blade width {2 * ty:.4g} m < "
                f"{2 * self.platform_half_width:.4g} m (pitch at the rim minus platform_gap)",
                "blade wider than the pitch")
        require(tz <= self.width / 2, "blade_chord", self.blade_chord,
                f"such that the blade axial extent {2 * tz:.4g} m <= width = {self.width:g} m",
                "blade longer than the platform")
        room = min(self.width / 2 - tz, self.platform_half_width - ty)
        require(self.root_fillet < room, "root_fillet", self.root_fillet,
                f"< {room:.4g} m (the platform's room round the airfoil)",
                "the fillet would run over the platform's edge")
        volume = np.pi * (self.r_rim**2 - self.r_bore**2) * self.width / self.sectors
        check_element_budget(volume, self.size)
        check_element_budget(4 * ty * tz * self.blade_height, self.blade_size, "blade_size")


def root_joint(params: RootJointParameters | None = None, **overrides) -> Mesh:
    """Mesh of the disk sector with its dovetail slot and the blade with its root.

    ``params`` defaults to :class:`RootJointParameters`; keyword ``overrides`` replace
    fields. Raises GeometryParameterError before Gmsh runs, GeometryBuildError if it fails.
    """
    p = params or RootJointParameters()
    p = replace(p, **overrides) if overrides else p
    p.validate()
    return g.run_builder("root_joint", as_dict(p), lambda: _build(p))


def _slot_profile(p: RootJointParameters) -> list[tuple[float, float]]:
    """Slot polygon [(rho, t)], open above the rim."""
    above = p.r_rim + p.neck_depth
    half_n, half_b = p.neck_width / 2, p.flank_t(p.r_flank_bottom)
    return [(p.r_flank_bottom, -half_b), (p.r_flank_bottom, half_b), (p.r_neck, half_n),
            (above, half_n), (above, -half_n), (p.r_neck, -half_n)]


def _root_profile(p: RootJointParameters) -> list[tuple[float, float]]:
    """Root + shank polygon [(rho, t)]: flanks on the slot flanks, clearance elsewhere."""
    c = p.clearance
    r_lo, r_hi = p.r_flank_bottom + c, p.r_neck - c
    half_s = p.neck_width / 2 - c
    top = p.r_platform + p.platform_thickness / 2  # overlaps the platform (fused)
    return [(r_lo, -p.flank_t(r_lo)), (r_lo, p.flank_t(r_lo)), (r_hi, p.flank_t(r_hi)),
            (r_hi, half_s), (top, half_s), (top, -half_s), (r_hi, -half_s),
            (r_hi, -p.flank_t(r_hi))]


def flank_rectangles(p: RootJointParameters) -> dict[str, tuple[np.ndarray, ...]]:
    """Root flank rectangles (origin, e1 axial, e2 outwards along the flank, outward
    normal of the root), in the assembled position (m)."""
    c = p.clearance
    r_lo, r_hi = p.r_flank_bottom + c, p.r_neck - c
    z0 = -p.width / 2
    e1 = np.array([0.0, 0.0, p.width])
    out = {}
    for name, side in (("root_left", -1.0), ("root_right", 1.0)):
        origin = local_to_xyz(0.0, r_lo, side * p.flank_t(r_lo), z0)
        e2 = local_to_xyz(0.0, r_hi, side * p.flank_t(r_hi), z0) - origin
        normal = np.cross(e1, e2)
        normal /= np.linalg.norm(normal)
        if normal[1] * side < 0:  # outward = away from the root's mid-plane
            normal = -normal
        out[name] = (origin, e1, e2, normal)
    return out


def _build(p: RootJointParameters) -> Mesh:
    occ = gmsh.model.occ
    ring = revolve_sector(p.r_bore, p.r_rim, -p.width / 2, p.width / 2, p.sectors)
    slot = axial_prism(0.0, _slot_profile(p), -p.width, p.width)
    cut, _ = occ.cut([(3, ring)], [(3, slot)])
    if len(cut) != 1:
        raise GeometryBuildError(f"disk is not one solid after cutting the slot: {cut}")
    rects = flank_rectangles(p)
    disk = g.imprint_faces(cut[0][1], [rectangle_face(*r[:3]) for r in rects.values()])
    blade = [_blade(p)]
    if p.root_fillet > 0.0:
        occ.synchronize()
        blade = [g.fillet_root(blade[0], _on_root(p), p.root_fillet)]
    if p.blade_layers:  # the airfoil above its root: a box meshed in prism layers
        blade = g.split_blade(blade[0], p.blade_split, p.r_tip, p.blade_chord,
                              p.blade_thickness, p.blade_stagger)
    occ.synchronize()
    cad = {"disk": occ.getMass(3, disk), "blade": sum(occ.getMass(3, v) for v in blade)}
    left, right = cyclic_faces([disk], p.sectors)
    g.set_periodic_rotation(left, right, p.phi)
    patches = _patch_surfaces(disk, blade, rects)
    spacing = 0.0
    for name, faces in patches.items():
        e1, e2 = rects[name][1:3]
        n1, n2 = face_nodes(p.contact_n_axial, p.contact_n_flank, e1, e2, p.contact_size)
        for face in faces:
            g.set_transfinite_rectangle(face, e1, n1, n2)
        spacing = max(spacing, np.linalg.norm(e1) / (n1 - 1), np.linalg.norm(e2) / (n2 - 1))
    _size_fields(p, rects, [f for faces in patches.values() for f in faces], spacing, blade)
    gmsh.model.addPhysicalGroup(3, [disk], name="disk")
    gmsh.model.addPhysicalGroup(3, blade, name="blade")
    gmsh.model.mesh.generate(3)
    return _read(p, disk, blade, rects, patches, left, right, cad)


def _blade(p: RootJointParameters) -> int:
    """Root + shank, platform and airfoil fused into one solid."""
    occ = gmsh.model.occ
    root = axial_prism(0.0, _root_profile(p), -p.width / 2, p.width / 2)
    hw = p.platform_half_width
    platform = axial_prism(0.0, [(p.r_platform, -hw), (p.r_platform, hw),
                                 (p.r_platform + p.platform_thickness, hw),
                                 (p.r_platform + p.platform_thickness, -hw)],
                           -p.width / 2, p.width / 2)
    x0 = p.r_platform + p.platform_thickness / 2
    x1 = p.blade_split if p.blade_layers else p.r_tip
    airfoil = staggered_blade(x0, x1, p.blade_chord, p.blade_thickness, p.blade_stagger)
    fused, _ = occ.fuse([(3, root)], [(3, platform), (3, airfoil)])
    if len(fused) != 1:
        raise GeometryBuildError(f"blade is not one solid: {fused}")
    return fused[0][1]


def _on_root(p: RootJointParameters):
    """Whether sampled points (k, 3) [m] lie where the airfoil meets the platform: on its
    top face, under the airfoil's section."""
    ty, tz = blade_half_extent(p.blade_chord, p.blade_thickness, p.blade_stagger)

    def on_root(xyz: np.ndarray) -> bool:
        return bool(np.abs(xyz[:, 0] - p.x_platform_top).max() < 1e-9
                    and np.all(np.abs(xyz[:, 1]) <= ty + 1e-9)
                    and np.all(np.abs(xyz[:, 2]) <= tz + 1e-9))

    return on_root


def _patch_surfaces(disk: int, blade: list[int], rects) -> dict[str, tuple[int, int]]:
    """{patch: (blade face, disk face)} located by centre and area."""
    disk_faces = g.boundary_surfaces([(3, disk)])
    blade_faces = g.boundary_surfaces([(3, v) for v in blade])
    out = {}
    for name, (origin, e1, e2, _) in rects.items():
        centre = origin + 0.5 * (e1 + e2)
        area = float(np.linalg.norm(np.cross(e1, e2)))
        out[name] = (g.surface_with_centre(blade_faces, centre, area),
                     g.surface_with_centre(disk_faces, centre, area))
    return out


def _size_fields(p: RootJointParameters, rects, patch_faces: list[int], spacing: float,
                 blade: list[int]) -> None:
    ty, tz = blade_half_extent(p.blade_chord, p.blade_thickness, p.blade_stagger)
    size = p.blade_size  # the airfoil's tets, or a layered airfoil's root at its section's
    if p.blade_layers:
        n_c, n_t = blade_cells(p.blade_chord, p.blade_thickness, p.blade_size)
        size = min(size, g.mesh_in_layers(blade[-1], p.blade_layers, p.blade_chord,
                                          p.blade_thickness, n_c, n_t))
    fields = [
        g.constant_field(p.size),
        g.add_distance_refinement(patch_faces, min(spacing, p.size), p.size,
                                  2 * p.flank_height),
        g.box_field(size, p.size, (p.r_platform, -ty, -tz), (p.r_tip + 1e-3, ty, tz)),
    ]
    if p.root_size > 0.0:
        top = (p.x_platform_top, 0.0, 0.0)
        fields.append(g.root_refinement(
            blade[0], p.x_platform_top, ty, tz, p.root_fillet, p.root_size, p.size,
            3 * p.blade_size, lambda t: bool(g.surfaces_on_plane([t], top, (1, 0, 0))),
            _on_root(p)))
    g.set_background_min(fields)


def _read(p, disk, blade, rects, patches, left, right, cad) -> Mesh:
    r = g.MeshReader()
    t_disk, t_blade, w_blade = r.tets([disk]), r.tets(blade), r.wedges(blade)
    tets = np.vstack([t_disk, t_blade])
    left_n, right_n = r.surface_nodes(left), r.surface_nodes(right)
    tip, exc, resp = g.tip_face_and_corners(blade[-1], p.r_tip)
    bore = [f for f in g.boundary_surfaces([(3, disk)]) if g.on_cylinder(f, p.r_bore)]
    sets = {
        "disk/bore": r.surface_nodes(bore),
        "cyclic/disk/left": left_n,
        "cyclic/disk/right": right_n,
        "blade/tip": r.surface_nodes(tip),
        "blade/excitation": r.point_node(exc),
        "blade/response": r.point_node(resp),
    }
    grids, contacts = ContactGrids(r.points, p.contact_size), {}
    for name, (f_blade, f_disk) in patches.items():
        patch = grids.patch(name, ("blade", {"tetra": t_blade, "wedge": w_blade},
                                     r.surface_nodes([f_blade])),
                            ("disk", {"tetra": t_disk}, r.surface_nodes([f_disk])),
                            rects[name], p.contact_n_axial, p.contact_n_flank)
        sets[f"contact/{name}/blade"], sets[f"contact/{name}/disk"] = patch_sets(patch)
        contacts[name] = patch
    derived = {"sector_angle": p.phi, "cad_volume": cad, "gmsh_min_sicn": g.gmsh_min_sicn()}
    return Mesh(
        model="root_joint",
        **grids.mesh_fields(),
        curved_edges=r.curved_edges,
        edge_nodes=r.edge_nodes,
        tetrahedra=tets,
        wedges=w_blade,
        bodies={"disk": np.arange(len(t_disk)),
                "blade": np.concatenate([np.arange(len(t_disk), len(tets)),
                                         len(tets) + np.arange(len(w_blade))])},
        node_sets=sets,
        cyclic={"disk": g.pair_cyclic(r.points, left_n, right_n, p.sectors)},
        contacts=contacts,
        parameters={**as_dict(p), "derived": derived},
    )
