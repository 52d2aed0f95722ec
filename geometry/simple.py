"""Reference models for finite-element checks: a cantilever beam and an annular sector."""

from __future__ import annotations

from dataclasses import dataclass

import gmsh
import numpy as np

from . import _gmsh as g
from .mesh import Mesh
from .params import (
    as_dict,
    check_ranges,
    param,
    positive_length,
    require,
)

#: Refuse meshes above this many estimated tets (a typo in a size, not a model).
MAX_TETS = 3_000_000


def check_element_budget(volume: float, size: float, name: str = "size") -> None:
    """Rough tet count ~ 8 V / size^3 (regular tets of edge ``size``); refuse huge meshes."""
    estimate = 8.0 * volume / size**3
    require(
        estimate <= MAX_TETS,
        name,
        size,
        f">= {(8.0 * volume / MAX_TETS) ** (1 / 3):.3g} m",
        f"about {estimate:.3g} tets estimated, limit {MAX_TETS}",
    )


# ------------------------------------------------------------------------ beam
@dataclass(frozen=True)
class BeamParameters:
    """Straight prismatic cantilever along +x, cross-section centred on the x axis."""

    length: float = positive_length(1.0, "beam length along x")
    width: float = positive_length(0.05, "cross-section width along y")
    height: float = positive_length(0.02, "cross-section height along z")
    size: float = positive_length(0.01, "target tet edge length")

    def validate(self) -> None:
        check_ranges(self)
        check_element_budget(self.length * self.width * self.height, self.size)


def beam(length: float = 1.0, width: float = 0.05, height: float = 0.02,
         size: float = 0.01) -> Mesh:
    """Tet mesh of the box [0, L] x [-w/2, w/2] x [-h/2, h/2] (m).

    Body "beam". Node sets:
      "beam/clamp"       nodes of the x = 0 face
      "beam/tip"         nodes of the x = L face
      "beam/tip_centre"  (1,) the node at (L, 0, 0) (a geometric point embedded in the tip)
    """
    p = BeamParameters(length, width, height, size)
    p.validate()
    return g.run_builder("beam", as_dict(p), lambda: _build_beam(p))


def _build_beam(p: BeamParameters) -> Mesh:
    occ = gmsh.model.occ
    vol = occ.addBox(0.0, -p.width / 2, -p.height / 2, p.length, p.width, p.height)
    centre = occ.addPoint(p.length, 0.0, 0.0)
    occ.synchronize()
    faces = g.boundary_surfaces([(3, vol)])
    clamp = g.surfaces_on_plane(faces, (0, 0, 0), (1, 0, 0))
    tip = g.surfaces_on_plane(faces, (p.length, 0, 0), (1, 0, 0))
    gmsh.model.mesh.embed(0, [centre], 2, tip[0])
    gmsh.model.addPhysicalGroup(3, [vol], name="beam")
    gmsh.option.setNumber("Mesh.MeshSizeMax", p.size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", p.size / 4)
    gmsh.model.mesh.generate(3)
    r = g.MeshReader()
    return Mesh(
        model="beam",
        points=r.points,
        curved_edges=r.curved_edges,
        edge_nodes=r.edge_nodes,
        tetrahedra=r.tets([vol]),
        bodies={"beam": np.arange(len(r.tets([vol])))},
        node_sets={
            "beam/clamp": r.surface_nodes(clamp),
            "beam/tip": r.surface_nodes(tip),
            "beam/tip_centre": r.point_node(centre),
        },
        parameters={**as_dict(p), "derived": {"cad_volume": {"beam": occ.getMass(3, vol)}}},
    )


# -------------------------------------------------------------- annular sector
@dataclass(frozen=True)
class AnnularSectorParameters:
    """Plain annular disk sector theta in [-phi/2, phi/2], z in [-w/2, w/2]."""

    sectors: int = param(8, "-", 3, 400, "number of sectors Ns", integer=True)
    r_inner: float = positive_length(0.05, "bore radius")
    r_outer: float = positive_length(0.15, "outer radius")
    width: float = positive_length(0.02, "axial width")
    size: float = positive_length(0.01, "target tet edge length")

    def validate(self) -> None:
        check_ranges(self)
        require(self.r_outer > self.r_inner, "r_outer", self.r_outer,
                f"> r_inner = {self.r_inner:g} m", "the annulus needs positive radial depth")
        volume = np.pi * (self.r_outer**2 - self.r_inner**2) * self.width / self.sectors
        check_element_budget(volume, self.size)


def annular_sector(sectors: int = 8, r_inner: float = 0.05, r_outer: float = 0.15,
                   width: float = 0.02, size: float = 0.01) -> Mesh:
    """Tet mesh of one sector of a plain annular disk, periodic cyclic faces.

    Body "disk" with ``cyclic["disk"]``. Node sets:
      "disk/bore"          nodes on r = r_inner
      "disk/rim"           nodes on r = r_outer
      "cyclic/disk/left"   nodes on theta = -phi/2 (sorted; pairing is in ``cyclic``)
      "cyclic/disk/right"  nodes on theta = +phi/2
    """
    p = AnnularSectorParameters(sectors, r_inner, r_outer, width, size)
    p.validate()
    return g.run_builder("annular_sector", as_dict(p), lambda: _build_annular(p))


def revolve_sector(r_inner: float, r_outer: float, z0: float, z1: float, sectors: int
                   ) -> int:
    """OCC volume of the annular sector r in [r_inner, r_outer], z in [z0, z1],
    theta in [-phi/2, phi/2], made by revolving a rectangle (exact planar cyclic faces)."""
    occ = gmsh.model.occ
    phi = 2 * np.pi / sectors
    rect = occ.addRectangle(r_inner, 0.0, 0.0, r_outer - r_inner, z1 - z0)
    occ.rotate([(2, rect)], 0, 0, 0, 1, 0, 0, np.pi / 2)  # into the xz plane, z from 0
    occ.translate([(2, rect)], 0, 0, z0 - 0.0)
    occ.rotate([(2, rect)], 0, 0, 0, 0, 0, 1, -phi / 2)
    out = occ.revolve([(2, rect)], 0, 0, 0, 0, 0, 1, phi)
    vols = [t for d, t in out if d == 3]
    return vols[0]


def cyclic_faces(volumes: list[int], sectors: int) -> tuple[list[int], list[int]]:
    """(left, right) planar faces of the volumes at theta = -phi/2 and +phi/2."""
    phi = 2 * np.pi / sectors
    faces = g.boundary_surfaces([(3, v) for v in volumes])

    def plane_normal(theta: float) -> tuple[float, float, float]:
        return (-np.sin(theta), np.cos(theta), 0.0)

    left = g.surfaces_on_plane(faces, (0, 0, 0), plane_normal(-phi / 2))
    right = g.surfaces_on_plane(faces, (0, 0, 0), plane_normal(phi / 2))
    return left, right


def _build_annular(p: AnnularSectorParameters) -> Mesh:
    occ = gmsh.model.occ
    vol = revolve_sector(p.r_inner, p.r_outer, -p.width / 2, p.width / 2, p.sectors)
    occ.synchronize()
    left, right = cyclic_faces([vol], p.sectors)
    g.set_periodic_rotation(left, right, 2 * np.pi / p.sectors)
    faces = g.boundary_surfaces([(3, vol)])
    bore = [f for f in faces if g.on_cylinder(f, p.r_inner)]
    rim = [f for f in faces if g.on_cylinder(f, p.r_outer)]
    gmsh.model.addPhysicalGroup(3, [vol], name="disk")
    gmsh.option.setNumber("Mesh.MeshSizeMax", p.size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", p.size / 4)
    gmsh.model.mesh.generate(3)
    r = g.MeshReader()
    tets = r.tets([vol])
    left_nodes, right_nodes = r.surface_nodes(left), r.surface_nodes(right)
    return Mesh(
        model="annular_sector",
        points=r.points,
        curved_edges=r.curved_edges,
        edge_nodes=r.edge_nodes,
        tetrahedra=tets,
        bodies={"disk": np.arange(len(tets))},
        node_sets={
            "disk/bore": r.surface_nodes(bore),
            "disk/rim": r.surface_nodes(rim),
            "cyclic/disk/left": left_nodes,
            "cyclic/disk/right": right_nodes,
        },
        cyclic={"disk": g.pair_cyclic(r.points, left_nodes, right_nodes, p.sectors)},
        parameters={**as_dict(p), "derived": {"cad_volume": {"disk": occ.getMass(3, vol)}}},
    )
