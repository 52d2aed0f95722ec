"""CAD files through Gmsh: STEP, BREP and IGES written by Gmsh's OpenCASCADE kernel (in
millimetres, as CAD tools write them), meshed and read as bodies in metres; touching solids
meshed with matching grids on their common face; a sector's cyclic faces meshed as each
other's images."""

import numpy as np
import pytest
import scipy.sparse.linalg as spl

from microslip.fe import cyclic, fem
from microslip.geometry.imported import MeshImportError, import_mesh
from microslip.geometry.sector import SectorSpec

STEEL = fem.Material(2.0e11, 0.3, 7850.0)


def _write(path, build):
    """A CAD file of what ``build()`` adds to Gmsh's OpenCASCADE model (mm)."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def _two_boxes(occ):
    """A 100 x 20 x 10 mm base and a 40 x 20 x 5 mm block on it (a damper on a platform)."""
    occ.addBox(0, 0, 0, 100, 20, 10)
    occ.addBox(20, 0, 10, 40, 20, 5)


def _ring_sector(occ):
    """One of 12 sectors of the ring r in [100, 200] mm, z in [0, 20] mm."""
    phi = 2 * np.pi / 12
    rect = occ.addRectangle(100, 0, 0, 100, 20)
    occ.rotate([(2, rect)], 0, 0, 0, 1, 0, 0, np.pi / 2)
    occ.rotate([(2, rect)], 0, 0, 0, 0, 0, 1, -phi / 2)
    occ.revolve([(2, rect)], 0, 0, 0, 0, 0, 1, phi)


@pytest.mark.parametrize(("suffix", "units"), [(".step", "SI"), (".brep", "mm-t-s")])
def test_touching_solids_become_bodies_with_matching_interfaces(tmp_path, suffix, units):
    path = _write(tmp_path / f"two{suffix}", _two_boxes)
    mesh = import_mesh(path, units, size=0.005).mesh
    assert sorted(mesh.bodies) == ["body1", "body2"]
    volumes = sorted(mesh.body_volume(b) for b in mesh.bodies)  # straight faces: exact
    np.testing.assert_allclose(volumes, [40 * 20 * 5e-9, 100 * 20 * 10e-9], rtol=1e-12)
    a, b = mesh.node_sets["interface/body1/body2"], mesh.node_sets["interface/body2/body1"]
    assert np.intersect1d(a, b).size == 0  # each body its own nodes
    assert np.isin(a, mesh.body_nodes("body1")).all() and np.isin(b, mesh.body_nodes("body2")).all()
    pa, pb = mesh.points[a], mesh.points[b]
    order_a, order_b = np.lexsort(pa.T), np.lexsort(pb.T)
    np.testing.assert_array_equal(pa[order_a], pb[order_b])  # node for node, exactly
    np.testing.assert_allclose(pa[:, 2], 0.010, atol=1e-12)  # on the common face z = 10 mm
    assert pa[:, 0].min() == pytest.approx(0.020) and pa[:, 0].max() == pytest.approx(0.060)


def test_iges_faces_are_sewn_into_a_solid(tmp_path):
    path = _write(tmp_path / "box.iges", lambda occ: occ.addBox(0, 0, 0, 100, 20, 10))
    mesh = import_mesh(path, size=0.005).mesh
    (body,) = mesh.bodies  # named as the IGES labels it ("COMPOUND")
    assert mesh.body_volume(body) == pytest.approx(2e-5, rel=1e-12)
    with pytest.raises(MeshImportError, match="declares its own unit"):
        import_mesh(path, "mm-t-s")


def _frequencies(mesh, nd: int, n: int = 4) -> np.ndarray:
    body = fem.assemble(mesh, "body1", STEEL)
    bore = mesh.node_sets["bore"]
    sector = cyclic.sector_model(body, bore, mesh.cyclic["body1"], nd)
    lam = spl.eigsh(sector.stiffness.tocsc(), k=n, M=sector.mass.tocsc(), sigma=0,
                    return_eigenvectors=False)
    return np.sqrt(np.sort(lam.real)) / (2 * np.pi)


def test_a_sector_is_meshed_with_matching_cyclic_faces(tmp_path):
    """The ring sector from STEP, its axis given: the cyclic faces Gmsh meshed as each other's
    images pair node for node; its frequencies converge with the element size (the coarse
    sector's within its distance to a finer one of the finest)."""
    from microslip.geometry.imported import Selection

    path = _write(tmp_path / "ring.step", _ring_sector)
    spec = SectorSpec(12, axis=(0.0, 0.0, 1.0))
    bore = {"bore": Selection(radius=0.1, tolerance=1e-6)}
    meshes = [import_mesh(path, sector=spec, sets=bore, size=h).mesh for h in (0.03, 0.015)]
    for mesh in meshes:
        assert mesh.cyclic["body1"].matching
        assert len(mesh.cyclic["body1"].left) > 10
    coarse, fine = (_frequencies(m, 2) for m in meshes)
    finest = _frequencies(import_mesh(path, sector=spec, sets=bore, size=0.01).mesh, 2)
    assert (np.abs(fine / finest - 1) < np.abs(coarse / finest - 1) + 1e-4).all()
    assert np.abs(fine / finest - 1).max() < 0.02  # P2 on this ring: within 2 %


def test_periodic_faces_about_an_offset_axis_in_brep_units(tmp_path):
    """The ring sector moved off the origin, as a BREP in millimetres: the axis' origin is
    given in metres and the model is in millimetres, and the periodic faces are still found
    (the cyclic faces match node for node)."""
    def moved(occ):
        _ring_sector(occ)
        occ.translate(occ.getEntities(3), 50.0, -30.0, 10.0)

    path = _write(tmp_path / "ring.brep", moved)
    spec = SectorSpec(12, axis=(0.0, 0.0, 1.0), origin=(0.05, -0.03, 0.01))
    mesh = import_mesh(path, "mm-t-s", sector=spec, size=0.03).mesh
    assert mesh.cyclic["body1"].matching


def test_a_curved_cad_face_keeps_its_arcs(tmp_path):
    """The ring sector from STEP meshed at 30 mm:
    its mid-edge nodes lie on the arcs, so its volume is the ring's, where the tetrahedra's
    chords lose the segments."""
    import dataclasses

    mesh = import_mesh(_write(tmp_path / "ring.step", _ring_sector), size=0.03).mesh
    assert len(mesh.curved_edges) > 0
    straight = dataclasses.replace(mesh, curved_edges=np.empty((0, 2), np.int64),
                                   edge_nodes=np.empty((0, 3)))
    exact = STEEL.density * 0.02 * np.pi / 12 * (0.2**2 - 0.1**2)  # [kg]
    error = {}
    for name, m in (("curved", mesh), ("straight", straight)):
        body = fem.assemble(m, "body1", STEEL)
        shift = np.zeros(body.n_dofs)
        shift[np.vstack([body.node_dofs, body.edge_dofs])[:, 0]] = 1.0
        error[name] = abs(shift @ body.mass @ shift / exact - 1)
    # Gmsh divides the arcs finer than 30 mm (its sizes follow the curvature): the chords
    # lose 4.1e-5 of the volume, the quadratic arcs 6.7e-8 (measured; the fourth power of
    # the angle against its square)
    assert error["curved"] < 1e-6 < 1e-5 < error["straight"]
