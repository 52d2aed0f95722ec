"""OCC solids and faces from plain coordinates (used inside a Gmsh session)."""

from __future__ import annotations

import gmsh
import numpy as np


def radial_frame(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """(e_r, e_t): in-plane unit radial and tangential vectors (3,) at angle ``theta``."""
    return (np.array([np.cos(theta), np.sin(theta), 0.0]),
            np.array([-np.sin(theta), np.cos(theta), 0.0]))


def local_to_xyz(theta: float, rho: float, t: float, z: float = 0.0) -> np.ndarray:
    """(3,) point at distance ``rho`` along e_r(theta), ``t`` along e_t(theta), height z."""
    e_r, e_t = radial_frame(theta)
    return rho * e_r + t * e_t + np.array([0.0, 0.0, z])


def _polygon_face(corners: np.ndarray) -> int:
    """Planar OCC face through the (k, 3) corner points, in order."""
    occ = gmsh.model.occ
    pts = [occ.addPoint(*map(float, c)) for c in corners]
    lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
    return occ.addPlaneSurface([occ.addCurveLoop(lines)])


def axial_prism(theta: float, profile, z0: float, z1: float) -> int:
    """OCC volume: the polygon ``profile`` [(rho, t), ...] in the local frame at ``theta``
    extruded along +z from z0 to z1 (m)."""
    corners = np.array([local_to_xyz(theta, r, t, z0) for r, t in profile])
    face = _polygon_face(corners)
    out = gmsh.model.occ.extrude([(2, face)], 0.0, 0.0, z1 - z0)
    return next(t for d, t in out if d == 3)


def rectangle_face(origin, e1, e2) -> int:
    """Planar OCC face of the rectangle origin + [0, 1] e1 + [0, 1] e2 (m)."""
    o, a, b = (np.asarray(v, float) for v in (origin, e1, e2))
    return _polygon_face(np.array([o, o + a, o + a + b, o + b]))


def rotate_z(dimtags, angle: float) -> None:
    """Rotate OCC entities about the z axis by ``angle`` (rad)."""
    gmsh.model.occ.rotate(dimtags, 0, 0, 0, 0, 0, 1, angle)


def blade_half_extent(chord: float, thickness: float, stagger_deg: float) -> tuple[float, float]:
    """(tangential y, axial z) half extents (m) of a chord x thickness rectangle whose chord
    makes ``stagger_deg`` with the axial direction."""
    s, c = np.sin(np.radians(stagger_deg)), np.cos(np.radians(stagger_deg))
    return (chord * s + thickness * c) / 2, (chord * c + thickness * s) / 2


def staggered_blade(x0: float, x1: float, chord: float, thickness: float,
                    stagger_deg: float) -> int:
    """OCC box x in [x0, x1] with a chord (along z) x thickness (along y) section centred on
    the x axis, then turned by the stagger angle about +x."""
    box = gmsh.model.occ.addBox(x0, -thickness / 2, -chord / 2, x1 - x0, thickness, chord)
    gmsh.model.occ.rotate([(3, box)], 0, 0, 0, 1, 0, 0, np.radians(stagger_deg))
    return box


def blade_cells(chord: float, thickness: float, size: float) -> tuple[int, int]:
    """(along the chord, through the thickness) cells of a prism-layered blade's section of
    cell size ``size`` [m] at most, two through the thickness at least."""
    return (max(2, int(np.ceil(chord / size - 1e-9))),
            max(2, int(np.ceil(thickness / size - 1e-9))))
