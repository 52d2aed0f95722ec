"""Cyclic sectors from any mesh: faces found by geometry, matching faces paired, faces meshed
independently tied by interpolation (the finer face follows the other), checked against
fields the tie must carry exactly and against the matching mesh's frequencies."""

import numpy as np
import pytest
import scipy.sparse.linalg as spl

from microslip.fe import cyclic, fem
from microslip.geometry import Mesh
from microslip.geometry.imported import import_mesh
from microslip.geometry.sector import SectorSpec, cyclic_boundaries
from microslip.geometry.structured import annulus

STEEL = fem.Material(2.0e11, 0.3, 7850.0)
SECTORS = 12


def _sector(mesh: Mesh) -> Mesh:
    """``mesh`` with its cyclic faces found (planes 2 pi / 12 apart) and paired or tied."""
    points, boundaries = cyclic_boundaries(mesh, SectorSpec(SECTORS))
    return Mesh(mesh.model, points, mesh.tetrahedra, mesh.bodies, mesh.node_sets, boundaries,
                hexahedra=mesh.hexahedra, wedges=mesh.wedges)


def _field(body, value):
    """(N,) complex DOF vector of the field ``value(x (n, 3)) -> (n, 3)`` at every DOF
    (vertices, and edge midpoints for quadratic elements)."""
    u = np.zeros(body.n_dofs, dtype=complex)
    u[body.node_dofs] = value(body.points)
    if len(body.edge_dofs):
        mid = body.points[body.local_nodes(body.edges.ravel()).reshape(-1, 2)].mean(axis=1)
        u[body.edge_dofs] = value(mid)
    return u


# Fields with the cyclic symmetry of a nodal diameter, linear in space (so any facet's shape
# functions interpolate them exactly): ND 0 the rotation about the axis and the axial
# translation; ND 1 the complex translation c = (1, i, 0): u(R x) = e^(i h phi) R u(x) needs
# R(phi) c = e^(-i phi) c, which holds
FIELDS = [
    (0, lambda x: np.stack([-x[:, 1], x[:, 0], 0 * x[:, 0]], axis=1)),
    (0, lambda x: np.stack([0 * x[:, 0], 0 * x[:, 0], 1 + 0 * x[:, 0]], axis=1)),
    (1, lambda x: np.stack([1 + 0 * x[:, 0], 1j + 0 * x[:, 0], 0 * x[:, 0]], axis=1)),
]


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("shape", ["hexahedron", "wedge", "tetra"])
def test_interpolated_tie_carries_cyclic_linear_fields_exactly(shape, order):
    """On a sector whose faces do not match, the expansion P_h rebuilds a cyclic field from
    its free DOFs on every DOF, the tied face's included (round-off)."""
    mesh = _sector(annulus(shape, SECTORS, cells=(3, 4, 2), stretch=0.4))
    assert not mesh.cyclic["ring"].matching
    body = fem.assemble(mesh, "ring", STEEL, order)
    for nd, value in FIELDS:
        sector = cyclic.sector_model(body, (), mesh.cyclic["ring"], nd)
        u = _field(body, value)
        rebuilt = sector.expansion @ u[sector.free_dofs]
        assert np.abs(rebuilt - u).max() < 1e-12 * np.abs(u).max()
    # a field of ND 1 is not one of ND 2: the tie at ND 2 cannot rebuild it
    u = _field(body, FIELDS[2][1])
    sector = cyclic.sector_model(body, (), mesh.cyclic["ring"], 2)
    assert np.abs(sector.expansion @ u[sector.free_dofs] - u).max() > 0.1


def _gmsh_ring(path, periodic: bool, size_left: float, size_right: float):
    """A sector (12) of the ring r in [0.1, 0.2] m, z in [0, 0.02] m, meshed by Gmsh in
    tetrahedra whose size goes from ``size_left`` to ``size_right`` across the sector;
    ``periodic``: the right face's mesh is the left one's image (matching faces)."""
    import gmsh

    phi = 2 * np.pi / SECTORS
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        rect = gmsh.model.occ.addRectangle(0.1, 0, 0, 0.1, 0.02)
        gmsh.model.occ.rotate([(2, rect)], 0, 0, 0, 1, 0, 0, np.pi / 2)  # the r-z plane
        gmsh.model.occ.rotate([(2, rect)], 0, 0, 0, 0, 0, 1, -phi / 2)
        out = gmsh.model.occ.revolve([(2, rect)], 0, 0, 0, 0, 0, 1, phi)
        gmsh.model.occ.synchronize()
        volume = next(t for d, t in out if d == 3)
        gmsh.model.addPhysicalGroup(3, [volume], name="ring")
        faces = [t for _, t in gmsh.model.getBoundary([(3, volume)], oriented=False)]
        centre = {t: gmsh.model.occ.getCenterOfMass(2, t) for t in faces}
        curved = [t for t in faces if gmsh.model.getType(2, t) != "Plane"]
        bore = min(curved, key=lambda t: np.hypot(*centre[t][:2]))
        gmsh.model.addPhysicalGroup(2, [bore], name="ring/bore")
        if periodic:
            angle = {t: np.arctan2(centre[t][1], centre[t][0]) for t in faces}
            left, right = min(faces, key=angle.get), max(faces, key=angle.get)
            c, s = np.cos(phi), np.sin(phi)
            gmsh.model.mesh.setPeriodic(2, [right], [left], [c, -s, 0, 0, s, c, 0, 0, 0, 0, 1,
                                                             0, 0, 0, 0, 1])
        size = gmsh.model.mesh.field.add("MathEval")
        across = f"(atan(y / x) + {phi / 2}) / {phi}"
        gmsh.model.mesh.field.setString(size, "F", f"{size_left} + ({size_right} - "
                                                  f"{size_left}) * {across}")
        gmsh.model.mesh.field.setAsBackgroundMesh(size)
        for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints",
                       "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{option}", 0)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def _frequencies(mesh: Mesh, nd: int, n: int = 6) -> np.ndarray:
    body = fem.assemble(mesh, "ring", STEEL)
    sector = cyclic.sector_model(body, mesh.node_sets["ring/bore"], mesh.cyclic["ring"], nd)
    lam = spl.eigsh(sector.stiffness.tocsc(), k=n, M=sector.mass.tocsc(), sigma=0,
                    return_eigenvectors=False)
    return np.sqrt(np.sort(lam.real)) / (2 * np.pi)


@pytest.mark.slow  # ~6 s: two Gmsh rings and their spectra (the figures of the README)
def test_matching_and_non_matching_faces_give_the_same_frequencies(tmp_path):
    """One sector meshed by Gmsh with periodic (matching) faces and freely (the left face
    finer, so the left face is the one tied): at each ND the first six frequencies differ by
    less than the matching mesh's own discretization error (its distance to a finer mesh)."""
    spec = SectorSpec(SECTORS)
    matching = import_mesh(_gmsh_ring(tmp_path / "m.msh", True, 0.012, 0.012), sector=spec).mesh
    free = import_mesh(_gmsh_ring(tmp_path / "n.msh", False, 0.008, 0.014), sector=spec).mesh
    fine = import_mesh(_gmsh_ring(tmp_path / "f.msh", True, 0.008, 0.008), sector=spec).mesh
    assert matching.cyclic["ring"].matching and not free.cyclic["ring"].matching
    tied = free.cyclic["ring"]
    assert len(tied.left) > len(tied.right)  # the left face is the slave here
    body = fem.assemble(free, "ring", STEEL)
    for nd, value in FIELDS:  # exact on a free tetrahedral mesh too (the slave: left)
        sector = cyclic.sector_model(body, (), tied, nd)
        u = _field(body, value)
        assert np.abs(sector.expansion @ u[sector.free_dofs] - u).max() < 1e-12
    for nd in (0, 3):  # real and complex sector matrices
        f_match, f_free, f_fine = (_frequencies(m, nd) for m in (matching, free, fine))
        discretization = np.abs(f_match - f_fine) / f_fine
        assert (np.abs(f_free - f_match) / f_match).max() < discretization.max(), nd


def test_faces_found_in_rounded_coordinates():
    """A deck written with a micrometre's resolution (coordinates rounded to 1e-6 m): the
    planar faces are still found whole and paired within a tolerance of twice that; a face
    named for a body the mesh does not have is refused."""
    ring = annulus("hexahedron", SECTORS, cells=(3, 4, 2))
    rounded = Mesh(ring.model, np.round(ring.points, 6), ring.tetrahedra, ring.bodies,
                   ring.node_sets, hexahedra=ring.hexahedra)
    _, boundaries = cyclic_boundaries(rounded, SectorSpec(SECTORS, tolerance=2e-6))
    assert boundaries["ring"].matching
    np.testing.assert_array_equal(boundaries["ring"].left, ring.node_sets["cyclic/left"])
    with pytest.raises(ValueError, match=r"\['rotor'\] are not bodies"):
        cyclic_boundaries(ring, SectorSpec(SECTORS, faces=(("rotor", "a", "b"),)))
