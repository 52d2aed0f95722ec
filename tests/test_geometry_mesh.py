"""The mesh contract (geometry.mesh) on small hand-made meshes: no Gmsh involved."""

import json

import meshio
import numpy as np
import pytest

from microslip.geometry.boundaries import ContactPatch, CyclicBoundary, MeshValidationError
from microslip.geometry.mesh import Mesh, boundary_triangles, rotation_z, signed_volumes
from microslip.geometry.quality import sicn

UNIT_TET = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])


def two_tets() -> tuple[np.ndarray, np.ndarray]:
    """Two unit tets, the second a copy shifted by +2 in x (distinct nodes)."""
    return np.vstack([UNIT_TET, UNIT_TET + [2.0, 0, 0]]), np.array([[0, 1, 2, 3], [4, 5, 6, 7]])


def test_signed_volume_of_unit_tet_is_one_sixth():
    assert signed_volumes(UNIT_TET, np.array([[0, 1, 2, 3]]))[0] == pytest.approx(1 / 6)
    assert signed_volumes(UNIT_TET, np.array([[0, 2, 1, 3]]))[0] == pytest.approx(-1 / 6)


def test_the_boundary_of_a_cube_of_six_tets_is_its_twelve_outward_triangles():
    from itertools import permutations

    corners = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], float)
    tets = []
    for order in permutations(range(3)):  # Kuhn's split: one tet per path 0 -> 7
        path = [0]
        for axis in order:
            path.append(path[-1] | (1 << axis))
        tets.append(path)
    tets = np.array(tets)
    flip = signed_volumes(corners, tets) < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    tri = boundary_triangles(tets)
    assert tri.shape == (12, 3)  # two per face: the inner faces are shared and left out
    # closed: every edge twice, once each way; outward: the divergence theorem's volume
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    assert sorted(map(tuple, edges)) == sorted(map(tuple, edges[:, ::-1]))
    p = corners[tri]
    volume = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6
    assert volume == pytest.approx(1.0, rel=1e-12)


def test_sicn_is_one_for_regular_and_negative_for_inverted_tet():
    w = np.array([[0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0],
                  [0.5, np.sqrt(3) / 6, np.sqrt(2 / 3)]])
    q = sicn(w * 0.003, np.array([[0, 1, 2, 3], [1, 2, 0, 3], [0, 2, 1, 3]]))
    np.testing.assert_allclose(q, [1, 1, -1], atol=1e-12)  # scale and vertex-cycle invariant
    flat = w.copy()
    flat[3, 2] = 1e-6  # sliver: SICN -> 0
    assert 0 < sicn(flat, np.array([[0, 1, 2, 3]]))[0] < 1e-4


def test_mesh_accepts_valid_data_and_freezes_arrays():
    pts, tets = two_tets()
    m = Mesh("demo", pts, tets, {"a": [0], "b": [1]}, node_sets={"a/base": [0, 1, 2]},
             parameters={"x": 1})
    assert m.tetrahedra.dtype == np.int64
    np.testing.assert_array_equal(m.body_nodes("b"), [4, 5, 6, 7])
    assert m.body_volume("a") == pytest.approx(1 / 6)
    with pytest.raises(ValueError):
        m.points[0, 0] = 5.0  # read-only


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda p, t: (p[:, :2], t, {"a": [0], "b": [1]}), "points"),
        (lambda p, t: (p, t[:, [0, 2, 1, 3]], {"a": [0], "b": [1]}), "positively oriented"),
        (lambda p, t: (p, t + 1, {"a": [0], "b": [1]}), "outside"),
        (lambda p, t: (p, t, {"a": [0]}), "belong to no body"),
        (lambda p, t: (p, t, {"a": [0, 1], "b": [1]}), "two bodies"),
        (lambda p, t: (p, np.array([[0, 1, 2, 3], [1, 5, 6, 7]]), {"a": [0], "b": [1]}),
         "shares nodes"),
    ],
)
def test_mesh_rejects_broken_data(change, message):
    pts, tets = two_tets()
    p, t, bodies = change(pts, tets)
    with pytest.raises(MeshValidationError, match=message):
        Mesh("bad", p, t, bodies)


def test_node_sets_must_be_sorted_unique_in_range():
    pts, tets = two_tets()
    with pytest.raises(MeshValidationError, match="sorted unique"):
        Mesh("bad", pts, tets, {"a": [0, 1]}, node_sets={"s": [2, 1]})
    with pytest.raises(MeshValidationError, match="outside"):
        Mesh("bad", pts, tets, {"a": [0, 1]}, node_sets={"s": [99]})


def rotated_pair_mesh(offset_error: float = 0.0) -> dict:
    """Tet 0 and its image under R(2 pi / 6) (tet 1), as one 'sector' body each side."""
    rot = rotation_z(2 * np.pi / 6)
    base = UNIT_TET + [3.0, 0, 0]
    image = base @ rot.T + offset_error
    return {"points": np.vstack([base, image]), "tetrahedra": [[0, 1, 2, 3], [4, 5, 6, 7]]}


def test_cyclic_boundary_checks_the_rotation():
    data = rotated_pair_mesh()
    cyc = CyclicBoundary(left=[0, 1, 2, 3], right=[4, 5, 6, 7], sectors=6)
    m = Mesh("cyc", data["points"], data["tetrahedra"], {"disk": [0, 1]}, cyclic={"disk": cyc})
    assert m.sector_angle("disk") == pytest.approx(np.pi / 3)
    bad = rotated_pair_mesh(offset_error=2e-9)  # just above the 1e-9 m tolerance
    with pytest.raises(MeshValidationError, match="right != R"):
        Mesh("cyc", bad["points"], bad["tetrahedra"], {"disk": [0, 1]}, cyclic={"disk": cyc})
    with pytest.raises(MeshValidationError, match=">= 3"):
        CyclicBoundary(left=[0], right=[1], sectors=2)


def contact_mesh(b_offset: int) -> Mesh:
    """Body 'a' (one tet) touching body 'b' on a 2 x 2 'grid' of its four nodes; with
    b_offset = 1 body b's nodes sit one sector (60 deg) back, as for the blisk damper."""
    rot = rotation_z(2 * np.pi / 6)
    a = UNIT_TET + [3.0, 0, 0]
    b_own = a @ rotation_z(-b_offset * 2 * np.pi / 6).T
    # body b is cyclic: give it a second tet (its rotated image) as the right face
    b_img = b_own @ rot.T
    pts = np.vstack([a, b_own, b_img])
    tets = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]
    patch = ContactPatch("p", "a", "b", [[0, 1], [2, 3]], [[4, 5], [6, 7]], [0, 0, 1.0], 1.0,
                         b_sector_offset=b_offset)
    cyc = CyclicBoundary(left=[4, 5, 6, 7], right=[8, 9, 10, 11], sectors=6)
    return Mesh("c", pts, tets, {"a": [0], "b": [1, 2]}, cyclic={"b": cyc},
                contacts={"p": patch})


@pytest.mark.parametrize("offset", [0, 1])
def test_contact_patch_coincides_after_the_sector_rotation(offset):
    m = contact_mesh(offset)
    np.testing.assert_allclose(m.patch_points("p", "a"), m.patch_points("p", "b"), atol=1e-12)


def test_contact_patch_with_wrong_offset_is_rejected():
    m = contact_mesh(1)
    p = m.contacts["p"]
    wrong = ContactPatch("p", "a", "b", p.nodes_a, p.nodes_b, p.normal, 1.0, b_sector_offset=0)
    with pytest.raises(MeshValidationError, match="do not coincide"):
        Mesh("c", m.points, m.tetrahedra, m.bodies, cyclic=m.cyclic, contacts={"p": wrong})


def test_contact_patch_validates_itself():
    with pytest.raises(MeshValidationError, match="2 x 2"):
        ContactPatch("p", "a", "b", [[0, 1]], [[2, 3]], [0, 0, 1], 1.0)
    with pytest.raises(MeshValidationError, match="unit"):
        ContactPatch("p", "a", "b", [[0, 1], [2, 3]], [[4, 5], [6, 7]], [0, 0, 2], 1.0)
    with pytest.raises(MeshValidationError, match="area"):
        ContactPatch("p", "a", "b", [[0, 1], [2, 3]], [[4, 5], [6, 7]], [0, 0, 1], 0.0)


def test_content_hash_is_stable_and_sensitive():
    pts, tets = two_tets()
    m1 = Mesh("h", pts, tets, {"a": [0], "b": [1]}, parameters={"size": 0.1})
    m2 = Mesh("h", pts.copy(), tets.copy(), {"a": [0], "b": [1]}, parameters={"size": 0.1})
    assert m1.content_hash == m2.content_hash
    assert len(m1.content_hash) == 64
    m3 = Mesh("h", pts, tets, {"a": [0], "b": [1]}, parameters={"size": 0.2})
    moved = pts.copy()
    moved[7] += 1e-12
    m4 = Mesh("h", moved, tets, {"a": [0], "b": [1]}, parameters={"size": 0.1})
    assert len({m1.content_hash, m3.content_hash, m4.content_hash}) == 3


def test_parameters_must_be_json(tmp_path):
    pts, tets = two_tets()
    with pytest.raises(MeshValidationError, match="JSON"):
        Mesh("j", pts, tets, {"a": [0, 1]}, parameters={"f": object()})


def test_write_msh_and_vtu_round_trip(tmp_path):
    pts, tets = two_tets()
    m = Mesh("io", pts, tets, {"a": [0], "b": [1]}, node_sets={"a/base": [0, 1, 2]},
             parameters={"p": 1})
    back = meshio.read(m.write(tmp_path / "m.msh"))
    np.testing.assert_allclose(back.points, pts)
    assert sum(len(c.data) for c in back.cells if c.type == "tetra") == 2
    assert {"a", "b", "a/base"} <= set(back.field_data)
    vtu = meshio.read(m.write(tmp_path / "m.vtu"))
    np.testing.assert_array_equal(np.flatnonzero(vtu.point_data["a.base"]), [0, 1, 2])
    xdmf = meshio.read(m.write(tmp_path / "m.xdmf"))
    assert len(xdmf.points) == 8
    json.dumps(m.parameters)


def test_a_gmsh_session_leaves_the_signal_handlers_in_place():
    """OpenCASCADE installs C-level signal handlers: after a session SIGTERM must still reach
    Python's handler (`microslip run` saves a partial file on it), not kill the process.
    In a child process: the signal goes to the whole process."""
    import subprocess
    import sys

    code = (
        "import os, signal, time\n"
        "got = []\n"
        "signal.signal(signal.SIGTERM, lambda s, f: got.append(s))\n"
        "from microslip import geometry\n"
        "geometry.blisk_sector(sectors=48)\n"
        "os.kill(os.getpid(), signal.SIGTERM)\n"
        "time.sleep(0.2)\n"
        "print('handled' if got else 'not handled')\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "handled", (r.returncode, r.stderr)
