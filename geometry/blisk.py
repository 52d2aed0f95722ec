"""Blisk sector with platforms and an underplatform wedge damper (Firrone & Zucca 5.3.2, Fig. 21).

Geometry (fundamental sector, theta in [-phi/2, phi/2], blade along +x)
-----------------------------------------------------------------------
* Disk + platform ring: annular sector r in [r_bore, r_platform], z in [-w/2, w/2].
* At each blade gap (theta = +-phi/2) a pocket is cut through the full axial width.
  In the gap's local frame (rho along the gap's radial line, t tangential, t < 0 towards
  the sector's own blade) the pocket is, from the top down: a slit of width
  ``platform_gap`` through the platform (platforms of neighbouring blades do not touch),
  two flanks inclined at ``alpha_left`` (t < 0) and ``alpha_right`` (t > 0) to the radial
  direction over the radial height ``pocket_flank_height``, then straight radial sides
  ``pocket_depth`` deep and a flat bottom. The flanks are the platform undersides.
* Blade: straight prism (chord x thickness, staggered by ``blade_stagger`` about the
  x axis) from inside the platform to r_platform + blade_height; fused with the disk.
* Damper: a trapezoidal prism (axial length ``damper_length``) whose two flanks lie on
  the pocket flanks (zero interference, Firrone & Zucca: Delta = 0) with its top face
  ``damper_top_width`` wide; it sits in the pocket at theta = +phi/2, i.e. between the
  sector's blade (right platform) and the next blade (left platform).

Bodies
------
"blisk"  (cyclic: ``mesh.cyclic["blisk"]``) and "damper" (free-free).

Contact patches (body_a = "damper", normal = damper flank outward normal)
------------------------------------------------------------------------
"damper_left"   damper flank (alpha_left) on the right platform of the sector's OWN blade;
                b_sector_offset = 0: points[nodes_a] == points[nodes_b].
"damper_right"  damper flank (alpha_right) on the left platform of the NEXT blade
                (sector +1). nodes_b are the fundamental sector's own left-platform flank
                nodes (pocket at theta = -phi/2); b_sector_offset = +1:
                points[nodes_a] == R(phi) points[nodes_b]; downstream the blisk side
                moves as exp(i h phi) R(phi) u_b at nodal diameter h.
Grid index i runs axially (n1 = ``contact_n_axial``, +z), j along the flank (n2 =
``contact_n_flank``, from the damper's bottom edge up to its top edge).

Node sets
---------
"blisk/bore"                       nodes on r = r_bore (constraint)
"blisk/blade_tip"                  nodes of the blade tip face
"blisk/excitation"                 (1,) blade tip corner with the smallest z
"blisk/response"                   (1,) blade tip corner with the largest z
"cyclic/blisk/left", "cyclic/blisk/right"   cyclic faces (pairing in ``cyclic``)
"contact/damper_left/damper", "contact/damper_left/blisk"
"contact/damper_right/damper", "contact/damper_right/blisk"   (blisk side: own nodes)
"damper/all"                       every damper node

``parameters["derived"]``: sector angle, CAD volumes per body (m^3), the damper's
nominal volume (m^3) and mass (kg), pocket radii.
"""

from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np

from . import _gmsh as g
from ._shapes import (
    axial_prism,
    blade_cells,
    blade_half_extent,
    local_to_xyz,
    radial_frame,
    rectangle_face,
    rotate_z,
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
class BliskParameters:
    """Blisk sector + wedge damper; defaults: 48 steel blades, alpha_L = alpha_R = 45 deg."""

    sectors: int = param(48, "-", 3, 400, "number of blades Ns", integer=True)
    r_bore: float = positive_length(0.10, "bore radius")
    r_platform: float = positive_length(0.20, "platform outer (flow-path) radius")
    width: float = positive_length(0.03, "axial width of disk and platforms")
    platform_thickness: float = positive_length(0.003, "platform thickness at the gap")
    platform_gap: float = positive_length(0.001, "tangential gap between platforms")
    pocket_flank_height: float = positive_length(0.006, "radial height of the pocket flanks")
    pocket_depth: float = positive_length(0.004, "radial depth of the pocket below the flanks")
    alpha_left: float = angle_deg(45.0, "left flank angle to the radial direction")
    alpha_right: float = angle_deg(45.0, "right flank angle to the radial direction")
    blade_height: float = positive_length(0.08, "blade height above the platform")
    blade_chord: float = positive_length(0.028, "blade chord")
    blade_thickness: float = positive_length(0.004, "blade thickness")
    blade_stagger: float = param(30.0, "deg", 0.0, 80.0, "chord angle to the axial direction")
    damper_height: float = positive_length(0.004, "radial height of the damper flanks")
    damper_top_width: float = positive_length(0.003, "tangential width of the damper top")
    damper_length: float = positive_length(0.024, "axial length of the damper")
    density: float = param(7850.0, "kg/m^3", 1.0, 25000.0, "damper density (steel)")
    size: float = positive_length(0.008, "global tet size")
    blade_size: float = positive_length(0.004, "tet size in the blade")
    contact_n_axial: int = grid_count(9, "contact points along the axis (n1)")
    contact_n_flank: int = grid_count(4, "contact points along the flank (n2)")
    contact_size: float = contact_size_param()
    root_fillet: float = root_fillet_param()
    root_size: float = root_size_param()
    blade_layers: int = blade_layers_param()

    # ------------------------------------------------------------ derived shape
    @property
    def phi(self) -> float:
        """Sector angle (rad)."""
        return 2 * np.pi / self.sectors

    @property
    def tan_sum(self) -> float:
        return np.tan(np.radians(self.alpha_left)) + np.tan(np.radians(self.alpha_right))

    @property
    def r_flank_top(self) -> float:
        """rho where the flanks meet the slit (platform underside at the gap)."""
        return self.r_platform - self.platform_thickness

    @property
    def r_flank_bottom(self) -> float:
        return self.r_flank_top - self.pocket_flank_height

    @property
    def r_pocket_bottom(self) -> float:
        return self.r_flank_bottom - self.pocket_depth

    @property
    def r_damper_top(self) -> float:
        """rho of the damper top: where the pocket is as wide as the damper top."""
        return self.r_flank_top - (self.damper_top_width - self.platform_gap) / self.tan_sum

    @property
    def r_damper_bottom(self) -> float:
        return self.r_damper_top - self.damper_height

    def flank_t(self, rho: float) -> tuple[float, float]:
        """(t_left, t_right) of the pocket flanks at rho (gap-local frame, m)."""
        drop = self.r_flank_top - rho
        return (-(self.platform_gap / 2 + drop * np.tan(np.radians(self.alpha_left))),
                self.platform_gap / 2 + drop * np.tan(np.radians(self.alpha_right)))

    @property
    def blade_split(self) -> float:
        """x [m] where a prism-layered blade (``blade_layers``) starts: above the platform's
        cylinder everywhere under the blade section, the short root below it meshed with
        the disk."""
        ty = self.blade_half_extent[0]
        sag = self.r_platform - np.sqrt(self.r_platform**2 - ty**2)
        return self.r_platform + max(3.0 * sag, 0.25 * self.blade_thickness) + self.root_fillet

    @property
    def damper_area(self) -> float:
        """Cross-section area of the trapezoidal damper (m^2)."""
        top = self.damper_top_width
        bottom = top + self.damper_height * self.tan_sum
        return 0.5 * (top + bottom) * self.damper_height

    @property
    def damper_volume(self) -> float:
        return self.damper_area * self.damper_length

    @property
    def blade_half_extent(self) -> tuple[float, float]:
        """(tangential, axial) half extents of the staggered blade section (m)."""
        return blade_half_extent(self.blade_chord, self.blade_thickness, self.blade_stagger)

    # ------------------------------------------------------------- validation
    def validate(self) -> None:
        """Ranges of every field, then the rules that make the geometry possible."""
        check_ranges(self)
        half = np.sin(self.phi / 2)
        require(self.r_platform > self.r_bore, "r_platform", self.r_platform,
                f"> r_bore = {self.r_bore:g} m", "the disk needs radial depth")
        pitch = 2 * self.r_platform * half
        require(self.platform_gap < 0.5 * pitch, "platform_gap", self.platform_gap,
                f"< {0.5 * pitch:.4g} m (half the pitch at r_platform)", "platforms must exist")
        ty, tz = self.blade_half_extent
        room = pitch - self.platform_gap
        require(2 * ty < room, "blade_chord", self.blade_chord,
                f"such that the staggered blade width {2 * ty:.4g} m < {room:.4g} m "
                "(pitch at r_platform minus platform_gap)", "blade wider than the pitch")
        require(2 * tz <= self.width, "blade_chord", self.blade_chord,
                f"such that the blade axial extent {2 * tz:.4g} m <= width = {self.width:g} m",
                "blade longer than the platform")
        depth = self.r_pocket_bottom - self.r_bore
        require(depth >= 0.2 * (self.r_platform - self.r_bore), "pocket_depth",
                self.pocket_depth, f"such that the pocket bottom {self.r_pocket_bottom:.4g} m "
                f"stays >= {self.r_bore + 0.2 * (self.r_platform - self.r_bore):.4g} m",
                "the pocket may use at most 80 % of the disk's radial depth")
        t_l, t_r = self.flank_t(self.r_flank_bottom)
        neck = 2 * self.r_pocket_bottom * half - (t_r - t_l)
        require(neck >= 0.2 * 2 * self.r_pocket_bottom * half, "pocket_flank_height",
                self.pocket_flank_height,
                f"such that the pocket width {t_r - t_l:.4g} m <= 80 % of the pitch "
                f"{2 * self.r_pocket_bottom * half:.4g} m at the pocket bottom",
                "neighbouring pockets would cut the blade's neck")
        require(self.damper_top_width > self.platform_gap, "damper_top_width",
                self.damper_top_width, f"> platform_gap = {self.platform_gap:g} m",
                "the damper does not fit the pocket: it would pass through the gap")
        room_h = self.r_damper_top - self.r_flank_bottom
        require(self.damper_height <= room_h + 1e-12, "damper_height", self.damper_height,
                f"<= {room_h:.4g} m (flank height left below the damper top)",
                "the damper does not fit the pocket: its flanks would run past the pocket flanks")
        require(self.damper_length <= self.width, "damper_length", self.damper_length,
                f"<= width = {self.width:g} m", "the damper does not fit the pocket axially")
        room_f = min(self.width / 2 - tz, pitch / 2 - self.platform_gap / 2 - ty)
        require(self.root_fillet < room_f, "root_fillet", self.root_fillet,
                f"< {room_f:.4g} m (the platform's room round the blade)",
                "the fillet would run over the platform's edge")
        volume = np.pi * (self.r_platform**2 - self.r_bore**2) * self.width / self.sectors
        check_element_budget(volume, self.size)
        check_element_budget(4 * ty * tz * self.blade_height, self.blade_size, "blade_size")


def blisk_sector(params: BliskParameters | None = None, **overrides) -> Mesh:
    """Mesh of the blisk fundamental sector and its wedge damper (see the module doc).

    ``params`` defaults to :class:`BliskParameters`; keyword ``overrides`` replace fields.
    Raises GeometryParameterError before Gmsh runs, GeometryBuildError if Gmsh fails.
    """
    p = _with_overrides(params or BliskParameters(), overrides)
    p.validate()
    return g.run_builder("blisk_sector", as_dict(p), lambda: _build(p))


def _with_overrides(p, overrides: dict):
    from dataclasses import replace

    return replace(p, **overrides) if overrides else p


# ------------------------------------------------------------------ building
def _pocket_profile(p: BliskParameters) -> list[tuple[float, float]]:
    """Pocket polygon [(rho, t)] in the gap-local frame, slit open above the platform."""
    t_lb, t_rb = p.flank_t(p.r_flank_bottom)
    r_above = p.r_platform + p.platform_thickness + p.platform_gap  # clear of the cylinder
    g2 = p.platform_gap / 2
    return [(p.r_pocket_bottom, t_lb), (p.r_flank_bottom, t_lb), (p.r_flank_top, -g2),
            (r_above, -g2), (r_above, g2), (p.r_flank_top, g2), (p.r_flank_bottom, t_rb),
            (p.r_pocket_bottom, t_rb)]


def _damper_profile(p: BliskParameters) -> list[tuple[float, float]]:
    """Damper trapezoid [(rho, t)] in the gap-local frame (bottom-left first, ccw)."""
    lb, rb = p.flank_t(p.r_damper_bottom)
    lt, rt = p.flank_t(p.r_damper_top)
    return [(p.r_damper_bottom, lb), (p.r_damper_bottom, rb), (p.r_damper_top, rt),
            (p.r_damper_top, lt)]


def flank_rectangles(p: BliskParameters) -> dict[str, tuple[np.ndarray, ...]]:
    """Damper flank rectangles (origin, e1 axial, e2 up the flank, outward normal), in
    the assembled position at the gap theta = +phi/2 (m)."""
    theta = p.phi / 2
    z0 = -p.damper_length / 2
    e1 = np.array([0.0, 0.0, p.damper_length])
    lb, rb = p.flank_t(p.r_damper_bottom)
    lt, rt = p.flank_t(p.r_damper_top)
    _, e_t = radial_frame(theta)
    out = {}
    for name, (tb, tt), side in (("damper_left", (lb, lt), -1.0), ("damper_right", (rb, rt), 1.0)):
        origin = local_to_xyz(theta, p.r_damper_bottom, tb, z0)
        e2 = local_to_xyz(theta, p.r_damper_top, tt, z0) - origin
        normal = np.cross(e1, e2)
        normal /= np.linalg.norm(normal)
        if normal @ e_t * side < 0:  # outward = away from the damper's mid-plane
            normal = -normal
        out[name] = (origin, e1, e2, normal)
    return out


def _build(p: BliskParameters) -> Mesh:
    occ = gmsh.model.occ
    phi = p.phi
    ring = revolve_sector(p.r_bore, p.r_platform, -p.width / 2, p.width / 2, p.sectors)
    margin = p.width
    pockets = []
    for theta in (phi / 2, -phi / 2):
        pockets.append((3, axial_prism(theta, _pocket_profile(p), -p.width / 2 - margin,
                                       p.width / 2 + margin)))
    cut, _ = occ.cut([(3, ring)], pockets)
    blade = _blade(p)
    fused, _ = occ.fuse(cut, [(3, blade)])
    if len(fused) != 1:
        raise GeometryBuildError(f"blisk is not one solid after fusing the blade: {fused}")
    if p.root_fillet > 0.0:
        occ.synchronize()
        fused = [(3, g.fillet_root(fused[0][1], _on_root(p), p.root_fillet))]
    rects = flank_rectangles(p)
    # Imprint the damper flanks on the pocket flanks: the right flank touches the NEXT
    # blade, whose left platform is the image of ours, so imprint its rotation by -phi.
    imprint = {"damper_left": rectangle_face(*rects["damper_left"][:3])}
    right = rectangle_face(*rects["damper_right"][:3])
    rotate_z([(2, right)], -phi)
    imprint["damper_right"] = right
    blisk = [g.imprint_faces(fused[0][1], list(imprint.values()))]
    if p.blade_layers:  # the blade above its root: a box meshed in prism layers
        blisk = g.split_blade(blisk[0], p.blade_split, p.r_platform + p.blade_height,
                              p.blade_chord, p.blade_thickness, p.blade_stagger)
    damper = axial_prism(phi / 2, _damper_profile(p), -p.damper_length / 2,
                         p.damper_length / 2)
    occ.synchronize()
    return _mesh_and_read(p, blisk, damper, rects)


def _blade(p: BliskParameters) -> int:
    """Blade prism along +x rooted inside the platform, above the pocket flanks (up to
    ``blade_split`` where its layers take over)."""
    x0 = p.r_platform - p.platform_thickness / 2
    x1 = p.blade_split if p.blade_layers else p.r_platform + p.blade_height
    return staggered_blade(x0, x1, p.blade_chord, p.blade_thickness, p.blade_stagger)


def _on_root(p: BliskParameters):
    """Whether sampled points (k, 3) [m] lie where the blade meets the platform: on its
    cylinder, under the blade's section."""
    ty, tz = p.blade_half_extent

    def on_root(xyz: np.ndarray) -> bool:
        return bool(np.abs(np.hypot(xyz[:, 0], xyz[:, 1]) - p.r_platform).max() < 1e-9
                    and np.all(np.abs(xyz[:, 1]) <= ty + 1e-9)
                    and np.all(np.abs(xyz[:, 2]) <= tz + 1e-9))

    return on_root


def _patch_surfaces(p: BliskParameters, blisk: list[int], damper: int, rects) -> dict:
    """{patch: (damper face, blisk face)} located by centre and area."""
    blisk_faces = g.boundary_surfaces([(3, v) for v in blisk])
    damper_faces = g.boundary_surfaces([(3, damper)])
    rot = g.rotation_z(-p.phi)
    found = {}
    for name, (origin, e1, e2, _) in rects.items():
        centre = origin + 0.5 * (e1 + e2)
        area = float(np.linalg.norm(np.cross(e1, e2)))
        own = rot @ centre if name == "damper_right" else centre
        found[name] = (g.surface_with_centre(damper_faces, centre, area),
                       g.surface_with_centre(blisk_faces, own, area))
    return found


def _mesh_and_read(p: BliskParameters, blisk: list[int], damper: int, rects) -> Mesh:
    occ = gmsh.model.occ
    cad = {"blisk": sum(occ.getMass(3, v) for v in blisk), "damper": occ.getMass(3, damper)}
    left, right = cyclic_faces(blisk, p.sectors)
    g.set_periodic_rotation(left, right, p.phi)
    patches = _patch_surfaces(p, blisk, damper, rects)
    spacing = 0.0
    for name, faces in patches.items():
        e1, e2 = rects[name][1:3]
        n1, n2 = face_nodes(p.contact_n_axial, p.contact_n_flank, e1, e2, p.contact_size)
        for face in faces:
            g.set_transfinite_rectangle(face, e1, n1, n2)
        spacing = max(spacing, np.linalg.norm(e1) / (n1 - 1), np.linalg.norm(e2) / (n2 - 1))
    patch_faces = [f for faces in patches.values() for f in faces]
    x_blade = p.r_platform
    ty, tz = p.blade_half_extent
    # the blade's tets at blade_size, or a layered blade's root at its section's cells
    blade_size = p.blade_size
    if p.blade_layers:
        n_c, n_t = blade_cells(p.blade_chord, p.blade_thickness, p.blade_size)
        blade_size = g.mesh_in_layers(blisk[-1], p.blade_layers, p.blade_chord,
                                      p.blade_thickness, n_c, n_t)
    fields = [
        g.constant_field(p.size),
        g.add_distance_refinement(patch_faces, min(spacing, p.size), p.size,
                                  3 * p.pocket_flank_height),
        g.box_field(min(blade_size, p.blade_size), p.size,
                    (x_blade - p.platform_thickness, -ty, -tz),
                    (p.r_platform + p.blade_height + 1e-3, ty, tz)),
    ]
    if p.root_size > 0.0:
        fields.append(g.root_refinement(blisk[0], p.r_platform, ty, tz, p.root_fillet,
                                        p.root_size, p.size, 3 * p.blade_size,
                                        lambda t: g.on_cylinder(t, p.r_platform), _on_root(p)))
    g.set_background_min(fields)
    gmsh.model.addPhysicalGroup(3, blisk, name="blisk")
    gmsh.model.addPhysicalGroup(3, [damper], name="damper")
    gmsh.model.mesh.generate(3)
    return _read(p, blisk, damper, rects, patches, left, right, cad)


def _read(p, blisk, damper, rects, patches, left, right, cad) -> Mesh:
    r = g.MeshReader()
    t_blisk, t_damper, w_blisk = r.tets(blisk), r.tets([damper]), r.wedges(blisk)
    tets = np.vstack([t_blisk, t_damper])
    bodies = {"blisk": np.concatenate([np.arange(len(t_blisk)),
                                       len(tets) + np.arange(len(w_blisk))]),
              "damper": np.arange(len(t_blisk), len(tets))}
    left_n, right_n = r.surface_nodes(left), r.surface_nodes(right)
    tip, exc, resp = g.tip_face_and_corners(blisk[-1], p.r_platform + p.blade_height)
    bore = [f for f in g.boundary_surfaces([(3, blisk[0])]) if g.on_cylinder(f, p.r_bore)]
    sets = {
        "blisk/bore": r.surface_nodes(bore),
        "blisk/blade_tip": r.surface_nodes(tip),
        "blisk/excitation": r.point_node(exc),
        "blisk/response": r.point_node(resp),
        "cyclic/blisk/left": left_n,
        "cyclic/blisk/right": right_n,
        "damper/all": np.unique(t_damper),
    }
    grids, contacts = ContactGrids(r.points, p.contact_size), {}
    for name, (f_damper, f_blisk) in patches.items():
        offset = 1 if name == "damper_right" else 0
        patch = grids.patch(name, ("damper", {"tetra": t_damper}, r.surface_nodes([f_damper])),
                            ("blisk", {"tetra": t_blisk, "wedge": w_blisk},
                             r.surface_nodes([f_blisk])),
                            rects[name], p.contact_n_axial, p.contact_n_flank,
                            b_angle=offset * p.phi, b_sector_offset=offset)
        sets[f"contact/{name}/damper"], sets[f"contact/{name}/blisk"] = patch_sets(patch)
        contacts[name] = patch
    derived = {
        "sector_angle": p.phi,
        "cad_volume": cad,
        "damper_volume": float(p.damper_volume),
        "damper_mass": float(p.damper_volume * p.density),
        "r_flank_top": float(p.r_flank_top),
        "r_damper_top": float(p.r_damper_top),
        "r_damper_bottom": float(p.r_damper_bottom),
        "gmsh_min_sicn": g.gmsh_min_sicn(),
    }
    return Mesh(
        model="blisk_sector",
        **grids.mesh_fields(),
        curved_edges=r.curved_edges,
        edge_nodes=r.edge_nodes,
        tetrahedra=tets,
        wedges=w_blisk,
        bodies=bodies,
        node_sets=sets,
        cyclic={"blisk": g.pair_cyclic(r.points, left_n, right_n, p.sectors)},
        contacts=contacts,
        parameters={**as_dict(p), "derived": derived},
    )
