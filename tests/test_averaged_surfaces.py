"""The contact grid apart from the mesh on named surfaces (geometry.averaging.averaged_surfaces,
geometry.pairing.patch_weights): side a's contact nodes gathered into patches about a
spacing wide, each patch one averaged point on each side.

Checked against what holds independently of the code: coincident surfaces meshed apart
give coincident points (both sides' averages over the same part of the surface, exact for
the linear geometry); a uniform pressure passed through the points arrives on each side as
that side's own consistent nodal loads (its tributary areas, ``nodal_areas_and_normals``);
and through the whole chain (averaged masters in Craig-Bampton, the assembly, the harmonic
balance) the two blocks pressed together carry the pressure uniformly and move as the exact
uniaxial solution, as the node-to-surface coupling does (tests/test_surface_contacts.py).
"""

import dataclasses

import numpy as np
import pytest
from blocks import two_blocks, upper_block
from test_surface_contacts import K_AREA, PRESS, E, H, L, P, model, pressed_mesh, reduced

from microslip.case.geometry_table import ContactDeclaration, with_contacts
from microslip.geometry.averaging import averaged_surfaces, surface_patches
from microslip.geometry.boundaries import AveragedContact
from microslip.geometry.pairing import (
    OUTSIDE,
    declare_contact,
    nodal_areas_and_normals,
    paired_contact,
    patch_weights,
)
from microslip.geometry.stored import load_mesh, save_mesh
from microslip.geometry.surfaces import surface_of
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import solve_point

SPACING = 0.012  # [m]: about 3 x 3 patches on the 40 mm faces


def blocks(lower=("hexahedron", (5, 5, 2)), upper=("tetra", (9, 9, 2))):
    """The two 40 x 40 x 20 mm blocks, their faces meshed apart."""
    return two_blocks(lower, upper, (L, L, H), (L, L, H), (0.0, 0.0))


@pytest.fixture(scope="module")
def averaged():
    mesh = blocks()
    c = declare_contact(mesh, "interface", ("upper/bottom", "lower/top"))
    return averaged_surfaces(dataclasses.replace(mesh, contacts={"interface": c}),
                             "interface", SPACING)


def test_patches_are_about_the_spacing_wide():
    """A 40 x 40 mm face at 12 mm: (40 / 12)^2 = 11 patches of 144 mm^2 on average; the
    seeds' covering radius spacing / sqrt 2 and Lloyd's sweeps keep them between 4 and 25
    (a square grid's 3 x 3 = 9 to 4 x 4 = 16, with room for the seeds' irregularity), and
    no patch wider than twice the spacing."""
    mesh = blocks()
    surface = surface_of(mesh.body_cells("upper"), mesh.node_sets["upper/bottom"])
    nodes, areas, _ = nodal_areas_and_normals(mesh.points, surface)
    label = surface_patches(mesh.points[nodes], areas, SPACING)
    assert 4 <= label.max() + 1 <= 25
    for c in range(label.max() + 1):
        xyz = mesh.points[nodes[label == c]]
        assert np.linalg.norm(np.ptp(xyz, axis=0)) <= 2 * SPACING
    again = surface_patches(mesh.points[nodes], areas, SPACING)
    np.testing.assert_array_equal(label, again)  # deterministic


def test_coincident_surfaces_give_coincident_points(averaged):
    """Both sides' averages cover the same part of the surface with the same weight phi_c,
    and x is linear on both flat faces: the points coincide to round-off, the gaps are 0."""
    c = averaged.contacts["interface"]
    assert isinstance(c, AveragedContact) and len(c.nodes_a) >= 4
    xa, xb = averaged.points[c.nodes_a], averaged.points[c.nodes_b]
    np.testing.assert_allclose(xa, xb, rtol=0, atol=1e-12 * L)
    np.testing.assert_allclose(c.gaps, 0.0, atol=1e-12 * L)
    np.testing.assert_allclose(c.normals, np.tile([0, 0, -1.0], (len(c.normals), 1)),
                               atol=1e-12)  # from the upper block (side a) into the lower
    assert c.areas.sum() == pytest.approx(L * L, rel=1e-12)


def test_a_uniform_pressure_arrives_as_each_sides_consistent_loads():
    """Forces p A_c at the points, spread back with the weights, are p int N_k dA on side a
    (exactly: the patches' phi_c sum to 1) and on side b up to the quadrature of side b's
    kinks across side a's facets: measured 4.1e-3, 1.03e-3, 2.6e-4 at 2, 4 (the default), 8
    sub-cells per facet edge (second order, as it should be); 2e-3 holds the default."""
    mesh = blocks()
    sa = surface_of(mesh.body_cells("upper"), mesh.node_sets["upper/bottom"])
    sb = surface_of(mesh.body_cells("lower"), mesh.node_sets["lower/top"])
    nodes_a, area_a, _ = nodal_areas_and_normals(mesh.points, sa)
    _, area_b, _ = nodal_areas_and_normals(mesh.points, sb)
    group = surface_patches(mesh.points[nodes_a], area_a, SPACING)
    Wa, Wb, areas = patch_weights(mesh.points, sa, mesh.points, sb, group, OUTSIDE * L)
    np.testing.assert_allclose(Wa.T @ areas, area_a, rtol=1e-12)
    np.testing.assert_allclose(Wb.T @ areas, area_b, rtol=2e-3)
    assert Wa.min() >= 0 and Wb.min() >= 0
    np.testing.assert_allclose(Wa.sum(axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(Wb.sum(axis=1), 1.0, rtol=1e-12)


def test_side_a_beyond_side_bs_edge_reads_it_at_the_edge():
    """The upper block 3 mm past the lower one's edge, inside a 5 mm tolerance, cut at
    2 mm: the patches along that edge lie beyond side b's 8 mm facets, where linear shape
    functions extrapolate (to -0.75 at 3 mm past an 8 mm facet). Side b is read at its
    edge instead: every weight >= 0, rows still sum to 1, and every patch stands for its
    whole area (the whole face touches, within the tolerance)."""
    mesh = two_blocks(("hexahedron", (5, 5, 2)), ("tetra", (20, 20, 2)), (L, L, H),
                      (L, L, H), (3e-3, 0.0))
    sa = surface_of(mesh.body_cells("upper"), mesh.node_sets["upper/bottom"])
    sb = surface_of(mesh.body_cells("lower"), mesh.node_sets["lower/top"])
    nodes_a, area_a, _ = nodal_areas_and_normals(mesh.points, sa)
    group = surface_patches(mesh.points[nodes_a], area_a, 2e-3)
    Wa, Wb, areas = patch_weights(mesh.points, sa, mesh.points, sb, group, 5e-3)
    assert Wa.min() >= 0 and Wb.min() >= 0
    np.testing.assert_allclose(Wb.sum(axis=1), 1.0, rtol=1e-12)
    assert areas.sum() == pytest.approx(L * L, rel=1e-12)


def test_patches_keep_to_one_face_of_a_sharp_edge():
    """Two faces at a right angle (a folded 30 x 30 mm sheet, nodes every 1 mm) cut at a
    10 mm spacing: by distance alone a patch at the fold takes nodes of both faces; with
    the normals' turn counted no patch holds nodes off the fold on both faces."""
    s = np.linspace(0.0, 0.03, 31)
    u, v = np.meshgrid(s, s, indexing="ij")
    flat = np.column_stack([u.ravel(), v.ravel(), np.zeros(u.size)])  # z = 0, normal +z
    wall = np.column_stack([np.zeros(u.size), v.ravel(), u.ravel()])[u.ravel() > 0]  # x = 0
    xyz = np.vstack([flat, wall])
    normals = np.vstack([np.tile([0.0, 0.0, 1.0], (len(flat), 1)),
                         np.tile([1.0, 0.0, 0.0], (len(wall), 1))])
    areas = np.full(len(xyz), 1e-6)
    on_flat = xyz[:, 0] > 1e-12  # off the fold
    on_wall = xyz[:, 2] > 1e-12

    def mixed(label):
        return sum(bool(on_flat[label == c].any() and on_wall[label == c].any())
                   for c in range(label.max() + 1))

    assert mixed(surface_patches(xyz, areas, 0.01)) > 0  # the check can fail
    assert mixed(surface_patches(xyz, areas, 0.01, normals)) == 0


def test_a_patch_over_opposite_faces_is_refused_in_one_line():
    """The block's top and bottom as one surface on the ground, cut at a spacing wider
    than the block: one patch whose normals cancel has no normal; the fault names the
    contact, the spacing and where."""
    mesh = upper_block("tetra", (4, 4, 2))
    skin = np.union1d(mesh.node_sets["upper/top"], mesh.node_sets["upper/bottom"])
    mesh = dataclasses.replace(mesh, node_sets={**mesh.node_sets, "skin": skin})
    c = declare_contact(mesh, "wrap", ("skin",), ground=True)
    with pytest.raises(ValueError, match=r"^contacts.wrap: spacing = 0.2 m puts a patch "
                       r"over faces turned too far apart at \(20, 20, 30\) mm"):
        averaged_surfaces(dataclasses.replace(mesh, contacts={"wrap": c}), "wrap", 0.2)


def test_pressed_blocks_carry_the_pressure_through_averaged_points(averaged):
    """Stiff contact, the whole chain: each point carries p times its area, and the top
    moves as the exact uniaxial stack plus the contact's compliance. The pressure's error
    is side b's quadrature (above, 1e-3 of the nodal loads, averaged over a patch); the
    top's error follows it smeared over the block (1e-4)."""
    pressure, top = pressed_mesh(averaged, 1e-3)
    np.testing.assert_allclose(pressure, 1.0, rtol=0, atol=1e-3)
    exact = -P * 2 * H / E - P / K_AREA
    assert top == pytest.approx(exact, rel=1e-4)


def test_the_averaged_contact_is_kept_by_the_stored_mesh(averaged, tmp_path):
    save_mesh(averaged, tmp_path / "m.h5")
    back = load_mesh(tmp_path / "m.h5")
    assert back.content_hash == averaged.content_hash
    assert isinstance(back.contacts["interface"], AveragedContact)


def drawn_areas(mesh, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(the area [m^2] a contact map draws in each point's colour, the areas the points
    stand for)."""
    from microslip.draw.maps import PatchGrid, cells

    grid = PatchGrid.from_mesh(mesh, name)
    k = len(grid.points)
    poly = cells(grid, np.arange(k), "pair")
    mm2 = poly.compute_cell_sizes(length=False, volume=False)["Area"]
    return np.bincount(poly.cell_data["pair"], mm2, k) * 1e-6, \
        paired_contact(mesh, name).pairing.areas


def test_the_map_draws_each_point_over_the_area_it_stands_for(averaged):
    """A map of averaged points draws side a's facets, each facet's corner quads (corner,
    edge midpoints, centroid) in the colour of the corner's patch. A corner quad's area is
    its node's share int N dA of a flat triangle or parallelogram, so the area drawn per
    point is the area it stands for (int phi_c dA over the face; the whole face touches):
    equal to round-off, every point drawn."""
    drawn, areas = drawn_areas(averaged, "interface")
    assert np.allclose(drawn, areas, rtol=1e-9, atol=0.0)


def test_a_narrow_strip_in_one_row_of_patches_is_drawn():
    """A 40 x 4 mm strip at a 4 mm spacing: ten patches in one row (none three at a facet,
    which a map of the patches' own dual cells needed); the map still draws each over its
    area, and the preview draws the face."""
    from microslip.draw.maps import PatchGrid, patch_borders
    from microslip.draw.previews import MeshView

    mesh = two_blocks(("hexahedron", (10, 1, 2)), ("tetra", (20, 2, 2)), (L, 0.004, H),
                      (L, 0.004, H), (0.0, 0.0))
    c = declare_contact(mesh, "strip", ("upper/bottom", "lower/top"))
    mesh = averaged_surfaces(dataclasses.replace(mesh, contacts={"strip": c}), "strip", 0.004)
    drawn, areas = drawn_areas(mesh, "strip")
    assert len(areas) == 10
    assert np.allclose(drawn, areas, rtol=1e-9, atol=0.0)
    # the borders between the ten: each crosses the 4 mm strip (mid-edge to centroid
    # segments, so at least 4 mm each across it), within it
    grid = PatchGrid.from_mesh(mesh, "strip")
    borders = patch_borders(grid)
    across = np.abs(np.diff(borders @ grid.axes @ [0, 1.0, 0], axis=1)).sum()
    assert across >= 9 * 4.0 * (1 - 1e-9)
    view = MeshView.from_mesh(mesh).patches[0]
    assert view.surface().n_cells == 80  # the upper block's 20 x 2 squares, two triangles each


def test_a_case_declares_the_spacing():
    """[geometry.contacts.<name>] spacing: the points average patches; 0: the nodes."""
    mesh = blocks()
    near = with_contacts(mesh, (ContactDeclaration("i", ("upper/bottom", "lower/top")),))
    far = with_contacts(mesh, (ContactDeclaration("i", ("upper/bottom", "lower/top"),
                                                  spacing=SPACING),))
    assert len(paired_contact(far, "i").pairing.nodes_a) < len(
        paired_contact(near, "i").pairing.nodes_a) // 4
    with pytest.raises(ValueError, match="contacts.i: spacing applies to named surfaces"):
        averaged_surfaces(far, "i", SPACING)  # averaged once already


@pytest.mark.parametrize("value", [-0.001, "4 mm"])
def test_a_bad_spacing_is_one_line(value):
    from microslip.case.geometry_table import _check_contacts

    out = []
    _check_contacts({"i": {"surfaces": ["a", "b"], "spacing": value}}, out)
    assert out == [f"geometry.contacts.i.spacing = {value!r}: expected a distance >= 0 [m] "
                   "(0: every node of the finer surface a contact point)"]


def test_a_block_on_the_ground_through_averaged_points():
    """The ground has no side b: the points average the block's face alone; the flat
    punch's stiffness over their areas (the face's whole) and the top's displacement as the
    node-by-node contact gives it (p H / E plus the punch's compliance; the averages read the
    uniform field exactly)."""
    from test_surface_contacts import stack

    mesh = averaged_surfaces(stack(None, ("tetra", (6, 6, 2))), "interface", SPACING)
    c = mesh.contacts["interface"]
    assert c.body_b is None and not len(c.nodes_b)
    st = reduced(mesh, stiffness=False)
    kn = 2 * np.sqrt(L * L / np.pi) * E
    assert st.patch_stiffness["interface"].total_normal == pytest.approx(kn, rel=1e-12)
    cm = model(mesh, st, 1e3, PRESS)
    p = OperatingPoint(100.0)
    r = solve_point(cm.hb, p)
    assert r.converged, r.reason
    assert cm.output_coefficients(r.x, p)[0, 0] == pytest.approx(
        -P * H / E - P * L * L / kn, rel=1e-9)


def test_a_neighbour_contact_averages_both_faces_under_the_sector_rotation():
    """The shrouded blisk's interlock (its two faces in neighbouring sectors): each point's
    partner, turned by one sector, coincides with it; the gaps are 0 and the areas sum to the
    model's own patch's."""
    from microslip import geometry
    from microslip.geometry.mesh import rotation_z

    mesh = geometry.shrouded_blisk()
    c = declare_contact(mesh, "lock", ("contact/shroud/a", "contact/shroud/b"), neighbour=True)
    mesh = averaged_surfaces(dataclasses.replace(mesh, contacts={**mesh.contacts, "lock": c}),
                             "lock", 0.004)
    lock = mesh.contacts["lock"]
    turned = mesh.points[lock.nodes_b] @ rotation_z(mesh.cyclic["blisk"].angle).T
    np.testing.assert_allclose(turned, mesh.points[lock.nodes_a], rtol=0, atol=1e-12)
    np.testing.assert_allclose(lock.gaps, 0.0, atol=1e-12)
    assert lock.areas.sum() == pytest.approx(paired_contact(mesh, "shroud").pairing.area,
                                             rel=1e-9)
