"""Gmsh-built models against independent facts: analytic volumes, exact rotations, planes."""

import gmsh
import numpy as np
import pytest

from microslip import geometry
from microslip.geometry.blisk import BliskParameters, blisk_sector
from microslip.geometry.full_disk import full_disk
from microslip.geometry.mesh import rotation_z
from microslip.geometry.quality import sicn
from microslip.geometry.root_joint import RootJointParameters, root_joint

# Minimum SICN accepted. Gmsh's optimiser works on tets below 0.3 (Mesh.OptimizeThreshold);
# 0.1 (condition number <= 10) keeps P2 stiffness well conditioned while allowing the few
# flat tets near the 30-45 deg corners of dovetail roots and damper wedges.
MIN_SICN = 0.1
MATCH = 1e-9  # m, the contract's matching tolerance


@pytest.fixture(scope="module")
def blisk():
    return blisk_sector()


@pytest.fixture(scope="module")
def blisk_skew():
    """Asymmetric pocket (alpha_L != alpha_R), fewer blades, so angles are distinguishable."""
    return blisk_sector(sectors=24, alpha_left=30.0, alpha_right=50.0, damper_height=0.003)


@pytest.fixture(scope="module")
def root():
    return root_joint()


ALL = ["blisk", "blisk_skew", "root"]


def radius(points):
    return np.hypot(points[:, 0], points[:, 1])


# ------------------------------------------------------------------ simple models
def test_beam_volume_sets_and_tip_centre():
    m = geometry.beam(length=0.5, width=0.04, height=0.02, size=0.01)
    # a box is exactly tetrahedralised: volume to round-off
    assert m.body_volume("beam") == pytest.approx(0.5 * 0.04 * 0.02, rel=1e-12)
    np.testing.assert_allclose(m.points[m.node_sets["beam/clamp"], 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(m.points[m.node_sets["beam/tip"], 0], 0.5, atol=1e-12)
    # every node on x = 0 is in the clamp set (completeness)
    assert np.array_equal(np.flatnonzero(np.abs(m.points[:, 0]) < 1e-12), m.node_sets["beam/clamp"])
    np.testing.assert_allclose(m.points[m.node_sets["beam/tip_centre"]], [[0.5, 0, 0]], atol=1e-12)
    assert sicn(m.points, m.tetrahedra).min() > MIN_SICN


@pytest.mark.parametrize("ns", [3, 5, 8])
def test_annular_sector_is_periodic_and_has_the_right_volume(ns):
    ri, ro, w = 0.05, 0.15, 0.02
    m = geometry.annular_sector(sectors=ns, r_inner=ri, r_outer=ro, width=w, size=0.012)
    cyc = m.cyclic["disk"]
    image = m.points[cyc.left] @ rotation_z(2 * np.pi / ns).T
    assert np.abs(image - m.points[cyc.right]).max() < MATCH
    theta = np.arctan2(m.points[:, 1], m.points[:, 0])
    np.testing.assert_allclose(theta[cyc.left], -np.pi / ns, atol=1e-9)
    np.testing.assert_allclose(radius(m.points[m.node_sets["disk/bore"]]), ri, atol=1e-12)
    # Straight-edged faceting of the r_inner / r_outer arcs with chords of length h loses
    # about h^2 / (12 r^2) of the area near each arc: < 0.5 % for h = 12 mm, r >= 50 mm.
    exact = np.pi * (ro**2 - ri**2) * w / ns
    assert m.body_volume("disk") == pytest.approx(exact, rel=5e-3)
    assert m.parameters["derived"]["cad_volume"]["disk"] == pytest.approx(exact, rel=1e-12)


def test_full_disk_of_annular_sector_closes_the_ring():
    m = geometry.annular_sector(sectors=4, size=0.02)
    f = full_disk(m)
    cyc = m.cyclic["disk"]
    n_face = len(cyc.left)
    assert len(f.points) == 4 * (len(m.points) - n_face)  # each face shared once
    assert f.body_volume("disk") == pytest.approx(4 * m.body_volume("disk"), rel=1e-12)
    # no duplicate coordinates left: the copies are joined node for node
    _, counts = np.unique(np.round(f.points / 1e-9).astype(np.int64), axis=0, return_counts=True)
    assert counts.max() == 1


# --------------------------------------------------------------- sector models
@pytest.mark.parametrize("name", ALL)
def test_cyclic_faces_match_node_for_node(name, request):
    m = request.getfixturevalue(name)
    (body, cyc), = m.cyclic.items()
    image = m.points[cyc.left] @ rotation_z(2 * np.pi / cyc.sectors).T
    assert np.abs(image - m.points[cyc.right]).max() < MATCH
    assert len(cyc.left) == len(np.unique(cyc.left)) > 10
    theta = np.arctan2(m.points[cyc.left, 1], m.points[cyc.left, 0])
    np.testing.assert_allclose(theta, -np.pi / cyc.sectors, atol=1e-9)
    np.testing.assert_array_equal(np.sort(cyc.left), m.node_sets[f"cyclic/{body}/left"])
    np.testing.assert_array_equal(np.sort(cyc.right), m.node_sets[f"cyclic/{body}/right"])


@pytest.mark.parametrize("name", ALL)
def test_contact_grids_coincide_and_are_structured(name, request):
    m = request.getfixturevalue(name)
    n1, n2 = m.parameters["contact_n_axial"], m.parameters["contact_n_flank"]
    assert len(m.contacts) == 2
    for cname, patch in m.contacts.items():
        assert patch.shape == (n1, n2)
        a, b = m.patch_points(cname, "a"), m.patch_points(cname, "b")
        assert np.abs(a - b).max() < MATCH
        assert np.intersect1d(patch.nodes_a, patch.nodes_b).size == 0  # distinct nodes
        # structured: constant steps along both grid directions, flat, normal orthogonal
        d1, d2 = np.diff(a, axis=0), np.diff(a, axis=1)
        assert np.abs(d1 - d1[0, 0]).max() < 1e-12 and np.abs(d2 - d2[0, 0]).max() < 1e-12
        assert abs(d1[0, 0] @ patch.normal) < 1e-12 and abs(d2[0, 0] @ patch.normal) < 1e-12
        span = np.linalg.norm(np.cross(a[-1, 0] - a[0, 0], a[0, -1] - a[0, 0]))
        assert patch.area == pytest.approx(span, rel=1e-12)
        # the sets carry exactly the grid nodes
        np.testing.assert_array_equal(m.node_sets[f"contact/{cname}/{patch.body_a}"],
                                      np.sort(patch.nodes_a.ravel()))
        np.testing.assert_array_equal(m.node_sets[f"contact/{cname}/{patch.body_b}"],
                                      np.sort(patch.nodes_b.ravel()))


@pytest.mark.parametrize("name", ALL)
def test_bodies_share_no_nodes_and_sets_live_on_their_body(name, request):
    m = request.getfixturevalue(name)
    nodes = {b: m.body_nodes(b) for b in m.bodies}
    (b1, n1), (b2, n2) = nodes.items()
    assert np.intersect1d(n1, n2).size == 0
    assert len(np.union1d(n1, n2)) == len(m.points)  # no orphan node
    for set_name, idx in m.node_sets.items():
        owner = set_name.split("/")[-1] if set_name.startswith("contact/") else (
            set_name.split("/")[1] if set_name.startswith("cyclic/") else set_name.split("/")[0])
        assert np.isin(idx, nodes[owner]).all(), set_name
        assert len(idx) > 0, set_name
    (body, cyc), = m.cyclic.items()
    assert np.intersect1d(m.node_sets[f"cyclic/{body}/left"],
                          m.node_sets[f"cyclic/{body}/right"]).size == 0


@pytest.mark.parametrize("name", ALL)
def test_quality_and_volume_against_cad(name, request):
    m = request.getfixturevalue(name)
    q = sicn(m.points, m.tetrahedra)
    assert q.min() > MIN_SICN
    # independent check of Gmsh's own figure (same definition, different code)
    assert q.min() == pytest.approx(m.parameters["derived"]["gmsh_min_sicn"], abs=1e-9)
    for body, cad in m.parameters["derived"]["cad_volume"].items():
        assert m.body_volume(body) == pytest.approx(cad, rel=5e-3), body


@pytest.mark.parametrize("name", ["blisk", "blisk_skew"])
def test_blisk_damper_volume_mass_and_flank_angles(name, request):
    m = request.getfixturevalue(name)
    p = BliskParameters(**{k: v for k, v in m.parameters.items()
                           if k not in ("kind", "derived")})
    ta, tb = np.tan(np.radians(p.alpha_left)), np.tan(np.radians(p.alpha_right))
    bottom = p.damper_top_width + p.damper_height * (ta + tb)
    volume = 0.5 * (p.damper_top_width + bottom) * p.damper_height * p.damper_length
    # a polyhedron is tetrahedralised exactly
    assert m.body_volume("damper") == pytest.approx(volume, rel=1e-10)
    assert m.parameters["derived"]["damper_mass"] == pytest.approx(volume * 7850.0, rel=1e-12)
    gap = p.phi / 2
    e_r = np.array([np.cos(gap), np.sin(gap), 0.0])
    e_t = np.array([-np.sin(gap), np.cos(gap), 0.0])
    for cname, alpha, side in (("damper_left", p.alpha_left, -1), ("damper_right",
                                                                   p.alpha_right, 1)):
        patch = m.contacts[cname]
        nrm = patch.normal
        # flank at alpha to the radial direction -> its normal at alpha to the tangent,
        # pointing outwards (centrifugal load closes the contact) and away from the damper
        assert nrm @ e_r == pytest.approx(np.sin(np.radians(alpha)), abs=1e-12)
        assert nrm @ e_t == pytest.approx(side * np.cos(np.radians(alpha)), abs=1e-12)
        flank = p.damper_height / np.cos(np.radians(alpha))
        assert patch.area == pytest.approx(flank * p.damper_length, rel=1e-12)
    # left flank: the sector's own blade; right flank: next blade (own nodes, offset 1)
    assert m.contacts["damper_left"].b_sector_offset == 0
    assert m.contacts["damper_right"].b_sector_offset == 1
    own = m.points[m.contacts["damper_right"].nodes_b]
    theta = np.arctan2(own[..., 1], own[..., 0])
    assert theta.max() < 0  # the fundamental sector's left platform


def test_blisk_node_sets_sit_where_documented(blisk):
    m, p = blisk, BliskParameters()
    np.testing.assert_allclose(radius(m.points[m.node_sets["blisk/bore"]]), p.r_bore, atol=1e-12)
    tip_x = p.r_platform + p.blade_height
    np.testing.assert_allclose(m.points[m.node_sets["blisk/blade_tip"], 0], tip_x, atol=1e-12)
    for s in ("blisk/excitation", "blisk/response"):
        assert len(m.node_sets[s]) == 1
        assert np.isin(m.node_sets[s], m.node_sets["blisk/blade_tip"]).all()
    ze = m.points[m.node_sets["blisk/excitation"], 2]
    zr = m.points[m.node_sets["blisk/response"], 2]
    assert ze < 0 < zr
    np.testing.assert_array_equal(m.node_sets["damper/all"], m.body_nodes("damper"))
    # every node at r = r_bore is in the bore set (completeness)
    at_bore = np.flatnonzero(np.abs(radius(m.points) - p.r_bore) < 1e-9)
    np.testing.assert_array_equal(at_bore, m.node_sets["blisk/bore"])


def test_root_joint_flanks_and_sets(root):
    m, p = root, RootJointParameters()
    beta = np.radians(p.flank_angle)
    for cname, side in (("root_left", -1), ("root_right", 1)):
        nrm = m.contacts[cname].normal
        np.testing.assert_allclose(nrm, [np.sin(beta), side * np.cos(beta), 0], atol=1e-12)
        flank = (p.flank_height - 2 * p.clearance) / np.cos(beta)
        assert m.contacts[cname].area == pytest.approx(flank * p.width, rel=1e-12)
    # the two flanks are mirror images in y
    a_l = m.patch_points("root_left", "a")
    a_r = m.patch_points("root_right", "a")
    np.testing.assert_allclose(a_l * [1, -1, 1], a_r, atol=1e-12)
    np.testing.assert_allclose(radius(m.points[m.node_sets["disk/bore"]]), p.r_bore, atol=1e-12)
    np.testing.assert_allclose(m.points[m.node_sets["blade/tip"], 0], p.r_tip, atol=1e-12)
    assert len(m.node_sets["blade/excitation"]) == len(m.node_sets["blade/response"]) == 1


def test_full_disk_joins_neighbour_contacts(blisk_skew):
    f = full_disk(blisk_skew)  # validation checks every patch coincides, offsets resolved
    ns = blisk_skew.cyclic["blisk"].sectors
    assert len(f.contacts) == 2 * ns
    assert f.contacts["damper_right#0"].body_b == "blisk"
    assert f.contacts["damper_right#0"].b_sector_offset == 0
    assert f.body_volume("blisk") == pytest.approx(ns * blisk_skew.body_volume("blisk"),
                                                   rel=1e-12)


def test_same_parameters_same_mesh_and_hash(root):
    again = root_joint()
    assert again.content_hash == root.content_hash
    np.testing.assert_array_equal(again.tetrahedra, root.tetrahedra)
    other = root_joint(contact_n_axial=5)
    assert other.content_hash != root.content_hash
    assert not gmsh.isInitialized()  # every session closed


def test_blisk_hash_is_reproducible(blisk):
    assert blisk_sector().content_hash == blisk.content_hash


def test_grid_resolution_is_a_parameter():
    m = root_joint(contact_n_axial=3, contact_n_flank=2, size=0.015)
    assert all(p.shape == (3, 2) for p in m.contacts.values())


def test_writes_msh_and_vtu(tmp_path, root):
    import meshio

    back = meshio.read(root.write(tmp_path / "root.msh"))
    np.testing.assert_allclose(back.points, root.points)
    assert {"disk", "blade", "contact/root_left/disk"} <= set(back.field_data)
    vtu = meshio.read(root.write(tmp_path / "root.vtu"))
    assert len(vtu.points) == len(root.points)


@pytest.mark.slow
@pytest.mark.parametrize("factor", [2.0, 0.5, 0.35])
@pytest.mark.parametrize("build", [blisk_sector, root_joint])
def test_size_sweep_keeps_every_guarantee(build, factor):
    """Coarse to fine meshes (bench sweep): validated contract, quality, CAD volume."""
    from microslip.bench.meshing import scaled

    defaults = BliskParameters() if build is blisk_sector else RootJointParameters()
    m = build(scaled(defaults, factor))  # Mesh validation: periodic + coincident grids
    assert sicn(m.points, m.tetrahedra).min() > MIN_SICN
    for body, cad in m.parameters["derived"]["cad_volume"].items():
        assert m.body_volume(body) == pytest.approx(cad, rel=5e-3)


@pytest.mark.parametrize("name, model", [("blisk", "blisk_sector"), ("root", "root_joint")])
def test_declared_names_are_the_meshed_ones(request, name, model):
    """Case files are checked against geometry.NAMES before anything is meshed."""
    m = request.getfixturevalue(name)
    names = geometry.NAMES[model]
    assert set(names["bodies"]) == set(m.bodies)
    assert set(names["patches"]) == set(m.contacts)
    assert set(names["node_sets"]) == set(m.node_sets)
