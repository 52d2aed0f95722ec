"""microslip.geometry: parametric and imported models -> tagged meshes (no physics here).

mesh            the mesh contract: a plain, immutable, validated data object
boundaries      what a mesh names beside its elements: cyclic faces, contacts, supports
elements        the solid element shapes a mesh holds, by their corners
params          parameter declarations: unit, default, checked range
blisk           blisk sector + wedge damper (Gmsh)
root_joint      dovetail disk sector + blade (Gmsh)
shroud          blisk sector with a z-notch tip shroud (Gmsh)
simple          reference models for FE checks: beam, annular sector
structured      structured meshes in every element shape, without Gmsh
full_disk       Ns rotated copies joined at the cyclic faces
sector          a sector of a cyclic structure from any mesh: axis, cyclic faces
imported        meshes from other tools read into a Mesh (SI units, corner nodes)
mesh_files      a mesh file of any format read, with its deck's materials and supports
body_groups     the bodies of an imported mesh from its element groups
abaqus          a reader of CalculiX / Abaqus input decks
deck_supports   the supports of Nastran and Ansys decks
materials       isotropic materials from the cards of Nastran and Ansys decks
cad             CAD files (STEP, IGES, BREP) meshed through Gmsh's OpenCASCADE kernel
surfaces        surfaces of a body and points projected onto them
pairing         two surfaces in contact, paired node by node
averaging       the contact grid apart from the mesh: points standing for cells
quality         element quality of linear tetrahedra
stored          a Mesh in an HDF5 file and back, exactly

Public API
----------
Mesh, CyclicBoundary, ContactPatch       the mesh contract (geometry.mesh, geometry.boundaries)
MODELS, PARAMETERS                       case-file model names -> builders / parameter classes
NAMES                                    bodies, patches, node sets of the contact models
beam, annular_sector                     reference models for FE checks (geometry.simple)
blisk_sector, BliskParameters            blisk sector + wedge damper (geometry.blisk)
root_joint, RootJointParameters          dovetail disk sector + blade (geometry.root_joint)
shrouded_blisk, ShroudParameters         blisk sector with a z-notch tip shroud (geometry.shroud)
full_disk, disk_node_map                 Ns rotated copies joined at the cyclic faces
sicn                                     element quality (geometry.quality)
GeometryParameterError, GeometryBuildError
Previews: microslip.draw.previews.render_previews(mesh, out_dir) (pyvista).
"""

from .blisk import BliskParameters, blisk_sector
from .boundaries import ContactPatch, CyclicBoundary, MeshValidationError, Support
from .full_disk import disk_node_map, full_disk
from .mesh import Mesh, rotation_z
from .params import GeometryBuildError, GeometryParameterError
from .quality import sicn
from .root_joint import RootJointParameters, root_joint
from .shroud import ShroudParameters, shrouded_blisk
from .simple import AnnularSectorParameters, BeamParameters, annular_sector, beam

MODELS = {  # name in a case file's [geometry] table -> builder(**parameters) -> Mesh
    "blisk_sector": blisk_sector,
    "root_joint": root_joint,
    "shrouded_blisk": shrouded_blisk,
    "beam": beam,
    "annular_sector": annular_sector,
}
PARAMETERS = {  # the same names -> their parameter dataclasses (units, defaults, ranges)
    "blisk_sector": BliskParameters,
    "root_joint": RootJointParameters,
    "shrouded_blisk": ShroudParameters,
    "beam": BeamParameters,
    "annular_sector": AnnularSectorParameters,
}

NAMES = {  # the bodies, contact patches and node sets each model makes (what a case may name,
    # checked before meshing; tests/test_geometry_models.py checks them against the meshes)
    "blisk_sector": {
        "bodies": ("blisk", "damper"),
        "patches": ("damper_left", "damper_right"),
        "node_sets": ("blisk/bore", "blisk/blade_tip", "blisk/excitation", "blisk/response",
                      "cyclic/blisk/left", "cyclic/blisk/right", "damper/all",
                      "contact/damper_left/damper", "contact/damper_left/blisk",
                      "contact/damper_right/damper", "contact/damper_right/blisk"),
    },
    "shrouded_blisk": {
        "bodies": ("blisk",),
        "patches": ("shroud",),
        "node_sets": ("blisk/bore", "blisk/shroud", "blisk/excitation", "blisk/response",
                      "cyclic/blisk/left", "cyclic/blisk/right", "contact/shroud/a",
                      "contact/shroud/b"),
    },
    "root_joint": {
        "bodies": ("blade", "disk"),
        "patches": ("root_left", "root_right"),
        "node_sets": ("disk/bore", "cyclic/disk/left", "cyclic/disk/right", "blade/tip",
                      "blade/excitation", "blade/response", "contact/root_left/blade",
                      "contact/root_left/disk", "contact/root_right/blade",
                      "contact/root_right/disk"),
    },
}

__all__ = [
    "MODELS",
    "NAMES",
    "PARAMETERS",
    "AnnularSectorParameters",
    "BeamParameters",
    "BliskParameters",
    "ContactPatch",
    "CyclicBoundary",
    "Support",
    "GeometryBuildError",
    "GeometryParameterError",
    "Mesh",
    "MeshValidationError",
    "RootJointParameters",
    "ShroudParameters",
    "annular_sector",
    "beam",
    "blisk_sector",
    "disk_node_map",
    "full_disk",
    "rotation_z",
    "root_joint",
    "shrouded_blisk",
    "sicn",
]
