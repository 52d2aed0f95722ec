"""microslip: Gmsh parametric models -> tagged meshes (no physics here).

Public API
----------
Mesh, CyclicBoundary, ContactPatch       the mesh contract (geometry.mesh)
MODELS, PARAMETERS                       case-file model names -> builders / parameter classes
beam, annular_sector                     reference models for FE checks (geometry.simple)
blisk_sector, BliskParameters            blisk sector + wedge damper (geometry.blisk)
root_joint, RootJointParameters          dovetail disk sector + blade (geometry.root_joint)
full_disk, disk_node_map                 Ns rotated copies joined at the cyclic faces
sicn                                     element quality (geometry.quality)
GeometryParameterError, GeometryBuildError
Previews: geometry.preview.render_previews(mesh, out_dir) (imports pyvista).
"""

from .blisk import BliskParameters, blisk_sector
from .full_disk import disk_node_map, full_disk
from .mesh import ContactPatch, CyclicBoundary, Mesh, MeshValidationError, rotation_z
from .params import GeometryBuildError, GeometryParameterError
from .quality import sicn
from .root_joint import RootJointParameters, root_joint
from .simple import AnnularSectorParameters, BeamParameters, annular_sector, beam

MODELS = {  # name in a case file's [geometry] table -> builder(**parameters) -> Mesh
    "blisk_sector": blisk_sector,
    "root_joint": root_joint,
    "beam": beam,
    "annular_sector": annular_sector,
}
PARAMETERS = {  # the same names -> their parameter dataclasses (units, defaults, ranges)
    "blisk_sector": BliskParameters,
    "root_joint": RootJointParameters,
    "beam": BeamParameters,
    "annular_sector": AnnularSectorParameters,
}

__all__ = [
    "MODELS",
    "PARAMETERS",
    "AnnularSectorParameters",
    "BeamParameters",
    "BliskParameters",
    "ContactPatch",
    "CyclicBoundary",
    "GeometryBuildError",
    "GeometryParameterError",
    "Mesh",
    "MeshValidationError",
    "RootJointParameters",
    "annular_sector",
    "beam",
    "blisk_sector",
    "disk_node_map",
    "full_disk",
    "rotation_z",
    "root_joint",
    "sicn",
]
