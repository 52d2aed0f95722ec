"""Supports that hold some directions only: against the same model with the held DOFs
eliminated by hand, a local frame against the model turned into it, a cylindrical support
on a cyclic sector against the full ring it is a sector of, and a deck's *BOUNDARY and
*TRANSFORM read as supports (or refused in one line)."""

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.spatial import cKDTree

from microslip.fe import bodies, cyclic, fem
from microslip.geometry import full_disk
from microslip.geometry.boundaries import CyclicBoundary, Support
from microslip.geometry.imported import MeshImportError, import_mesh
from microslip.geometry.mesh import Mesh, rotation_z
from microslip.geometry.structured import annulus, block

STEEL = fem.Material(2.0e11, 0.3, 7850.0)


def _eigenvalues(K, M) -> np.ndarray:
    return sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)


@pytest.fixture(scope="module")
def beam():
    mesh = block("hexahedron", (0.2, 0.02, 0.02), (6, 2, 2))
    return mesh, fem.assemble(mesh, "block", STEEL)


def test_held_directions_are_the_dofs_eliminated_by_hand(beam):
    mesh, body = beam
    clamp = mesh.node_sets["block/clamp"]
    held = np.array([True, False, True])  # x and z held, y free
    model = cyclic.sector_model(body, supports=[Support(clamp, held)])
    # by hand: the x and z DOFs of the face's vertices and of its edges' mid nodes
    drop = np.concatenate([body.dofs_of_nodes(clamp)[:, held].ravel(),
                           body.edge_dofs[body.set_edges(clamp)][:, held].ravel()])
    keep = np.setdiff1d(np.arange(body.n_dofs), drop)
    expected = _eigenvalues(body.stiffness[keep][:, keep], body.mass[keep][:, keep])
    # the same matrices up to the order of the coordinates: round-off only
    np.testing.assert_allclose(_eigenvalues(model.stiffness, model.mass), expected,
                               rtol=1e-9, atol=1e-6 * expected.max())
    # one rigid mode, the slide along y (free on the face); x and z held leave no other
    assert abs(expected[0]) < 1e-6 * expected[1] and expected[1] > 1.0
    assert model.n_free == len(keep)


def test_a_local_frame_is_the_model_turned_into_it(beam):
    mesh, body = beam
    clamp = mesh.node_sets["block/clamp"]
    turn = sla.expm(np.cross(np.eye(3), [0.3, -0.5, 0.8]))  # a rotation (3, 3)
    moved = Mesh("block", mesh.points @ turn.T, mesh.tetrahedra, mesh.bodies,
                 node_sets=mesh.node_sets, hexahedra=mesh.hexahedra)
    turned = fem.assemble(moved, "block", STEEL)
    held = np.array([False, True, True])
    plain = cyclic.sector_model(body, supports=[Support(clamp, held)])
    local = cyclic.sector_model(turned, supports=[Support(clamp, held, "rectangular",
                                                          axes=turn.T)])
    a, b = (_eigenvalues(m.stiffness, m.mass) for m in (plain, local))
    np.testing.assert_allclose(b[3:], a[3:], rtol=1e-8)  # (one rigid mode: sliding in x)


def _ring_sector(sectors: int) -> Mesh:
    """A ring sector with its cyclic faces paired (right = R(phi) left)."""
    ring = annulus("hexahedron", sectors, cells=(2, 3, 1), radii=(0.1, 0.14), width=0.02)
    left, right = ring.node_sets["cyclic/left"], ring.node_sets["cyclic/right"]
    image = ring.points[left] @ rotation_z(2 * np.pi / sectors).T
    _, order = cKDTree(ring.points[right]).query(image)
    boundary = CyclicBoundary(left, right[order], sectors)
    return Mesh("annulus", ring.points, ring.tetrahedra, ring.bodies,
                node_sets=ring.node_sets, cyclic={"ring": boundary}, hexahedra=ring.hexahedra)


def test_a_cylindrical_support_on_a_sector_is_the_full_ring_held_radially():
    """The bore held radially only (free to turn and to slide along the axis): the sector's
    spectra over every nodal diameter are the full ring's."""
    sectors = 6
    sector = _ring_sector(sectors)
    disk = full_disk(sector)
    radial = np.array([True, False, False])
    body = fem.assemble(sector, "ring", STEEL)
    found = []
    for h in range(sectors // 2 + 1):
        model = cyclic.sector_model(body, (), sector.cyclic["ring"], h,
                                    [Support(sector.node_sets["ring/bore"], radial,
                                             "cylindrical")])
        lam = _eigenvalues(model.stiffness, model.mass)
        found += list(lam) * (1 if h in (0, sectors // 2) else 2)  # +-h: a pair
    bore = np.unique(np.concatenate([v for k, v in disk.node_sets.items()
                                     if k.startswith("ring/bore")]))
    whole = fem.assemble(disk, "ring", STEEL)
    full = cyclic.sector_model(whole, supports=[Support(bore, radial, "cylindrical")])
    expected = _eigenvalues(full.stiffness, full.mass)
    found = np.sort(found)
    assert len(found) == len(expected)
    # two rigid modes (the turn about the axis, the slide along it), then the same spectrum
    assert np.abs(expected[:2]).max() < 1e-6 * expected[2]
    np.testing.assert_allclose(found[2:], expected[2:], rtol=1e-8)


DECK = """*NODE, NSET=ALL
{nodes}
*ELEMENT, TYPE=C3D8, ELSET=BLOCK
{elements}
*NSET, NSET=END
{end}
*TRANSFORM, NSET=END, TYPE=C
0., 0., 0., 0., 0., 1.
*BOUNDARY
END, 1, 1
*BOUNDARY
{corner}, 2, 3, 0.
{tail}
"""


def _deck(tmp_path, tail: str = "", mesh=None):
    mesh = mesh or block("hexahedron", (0.2, 0.02, 0.02), (4, 1, 1))
    nodes = "\n".join(f"{i + 1}, {x!r}, {y!r}, {z!r}" for i, (x, y, z) in
                      enumerate(mesh.points.tolist()))
    elements = "\n".join(f"{i + 1}, " + ", ".join(str(n + 1) for n in row)
                         for i, row in enumerate(mesh.hexahedra))
    end = ", ".join(str(n + 1) for n in mesh.node_sets["block/tip"])
    corner = int(mesh.node_sets["block/clamp"][0]) + 1
    path = tmp_path / "deck.inp"
    path.write_text(DECK.format(nodes=nodes, elements=elements, end=end, corner=corner,
                                tail=tail))
    return path, mesh, corner - 1


def test_a_decks_boundary_is_read_as_supports(tmp_path):
    path, mesh, corner = _deck(tmp_path, "*BOUNDARY\nEND, ENCASTRE\n*STEP\n*STATIC\n*END STEP")
    read = import_mesh(path).mesh
    supports = read.supports
    # END: radial (in its cylindrical frame about z) and then everything (ENCASTRE's
    # translations); the corner: y and z of the global frame
    tip = set(mesh.node_sets["block/tip"].tolist())
    by_name = {n: (set(s.nodes.tolist()), s.held.tolist(), s.frame) for n, s in
               supports.items()}
    assert by_name == {"boundary/END/rthetaz": (tip, [True, True, True], "cylindrical"),
                       "boundary/global/yz": ({corner}, [False, True, True], "global")}
    assert np.allclose(supports["boundary/END/rthetaz"].axes[2], [0, 0, 1])


@pytest.mark.parametrize(("tail", "words"), [
    ("*BOUNDARY\nEND, 2, 2, 0.001", "non-zero displacement is a load"),
    ("*BOUNDARY\nEND, 11, 11", "solids have DOFs 1-3"),
    ("*BOUNDARY, TYPE=VELOCITY\nEND, 1, 1", "only supports"),
    ("*TRANSFORM, NSET=END, TYPE=S\n1, 0, 0, 0, 1, 0", "TYPE=R (rectangular)"),
])
def test_what_a_support_cannot_be_is_one_line(tmp_path, tail, words):
    path, _, _ = _deck(tmp_path, tail)
    with pytest.raises(MeshImportError) as err:
        import_mesh(path)
    assert words in str(err.value) and "\n" not in str(err.value)


def _imported_case() -> dict:
    import tomllib
    from pathlib import Path

    cases = Path(__file__).parent.parent / "cases"
    data = tomllib.loads((cases / "13_imported_blade.toml").read_text())
    data["geometry"]["file"] = str(cases / "imported_blade.inp")
    return data


@pytest.mark.parametrize(("supports", "words"), [
    ([{"set": "TIP", "held": ["r"]}], "among ['x', 'y', 'z']"),
    ([{"set": "TIP", "held": ["x"], "frame": "polar"}], "expected one of ['global', "),
    ([{"set": "TIP", "held": []}], "non-empty list"),
    ([{"set": "TIP"}], "held: missing; the directions held, among ['x', 'y', 'z']"),
    ([{"set": "TIP", "held": ["x"], "axis": [0, 0, 1]}], "axis: unknown key"),
    ([{"set": "TIP", "hold": ["x"]}], "hold: unknown key"),  # not "held: missing" too
    ("TIP", "expected a list of tables"),
])
def test_a_bad_support_in_a_case_is_one_line(supports, words):
    from case_helpers import case_faults

    def mutate(data):
        data["reduction"]["bodies"]["BLADE"]["supports"] = supports

    faults = case_faults(_imported_case(), mutate)
    assert len(faults) == 1 and words in faults[0], faults


def test_a_support_on_a_master_or_a_missing_set_is_one_line():
    from case_helpers import case_faults

    def on_master(data):
        data["reduction"]["bodies"]["BLADE"]["supports"] = [{"set": "TIP", "held": ["x"]}]

    def missing(data):
        data["reduction"]["bodies"]["BLADE"]["supports"] = [{"set": "HUB", "held": ["x"]}]

    (fault,) = case_faults(_imported_case(), on_master)
    assert "held by a support" in fault and "masters need DOFs of their own" in fault
    (fault,) = case_faults(_imported_case(), missing)
    assert fault.startswith("reduction.bodies.BLADE.supports[0].set = 'HUB': no such node set")


def test_a_reduced_body_keeps_its_supports_and_its_cache_key_tells_them_apart(beam, tmp_path):
    """Craig-Bampton on a beam held at one end in y and z only (free to slide along x): its
    first frequencies against the unreduced supported model's; the cache keeps the two
    support choices apart."""

    mesh, body = beam
    clamp = mesh.node_sets["block/clamp"]
    specs = {held: bodies.BodySpec("block", STEEL, master_sets=("block/tip",),
                                      supports=(Support(clamp, np.array(held)),), n_modes=20)
             for held in ((False, True, True), (True, True, True))}
    for held, spec in specs.items():
        (model,) = bodies.reduce_body(mesh, spec, cache_dir=tmp_path).values()
        exact = _eigenvalues(*(m for m in (lambda s: (s.stiffness, s.mass))(
            cyclic.sector_model(body, supports=spec.supports))))
        reduced = sla.eigh(model.stiffness, model.mass, eigvals_only=True)
        # held in y and z only, the end face slides along x and turns about y and z
        rigid = 3 if not held[0] else 0
        assert np.abs(exact[:rigid]).max(initial=0) < 1e-9 * exact[rigid]
        assert np.abs(reduced[:rigid]).max(initial=0) < 1e-9 * exact[rigid]
        # the first four elastic modes: Craig-Bampton's truncation to 20 fixed-interface
        # modes on this coarse beam costs up to 5.5e-4 (measured; 40 modes 6e-5)
        np.testing.assert_allclose(reduced[rigid:rigid + 4], exact[rigid:rigid + 4],
                                   rtol=1e-3)
    # held in every direction is clamped: the same reduced model as clamped_sets gives
    clamped = bodies.BodySpec("block", STEEL, master_sets=("block/tip",),
                                 clamped_sets=("block/clamp",), n_modes=20)
    a, b = (sla.eigh(m.stiffness, m.mass, eigvals_only=True) for m in (
        model, *bodies.reduce_body(mesh, clamped).values()))
    np.testing.assert_allclose(a, b, rtol=1e-9)
    assert len(list(tmp_path.glob("cb-*.h5"))) == 2


def test_a_decks_surfaces_are_node_sets_of_their_faces(tmp_path):
    """*SURFACE by element faces (Abaqus' S1-S6) and by nodes: node sets of those names."""
    tail = ("*ELSET, ELSET=LAST\n4\n*SURFACE, NAME=TipFace\nLAST, S4\n"
            "*SURFACE, NAME=BOTTOM, TYPE=ELEMENT\n1, S1\n2, S1\n"
            "*SURFACE, NAME=ENDS, TYPE=NODE\nEND, 1.0\n")  # (a node surface's weight)
    path, mesh, _ = _deck(tmp_path, tail)
    sets = import_mesh(path).mesh.node_sets
    tip = mesh.node_sets["block/tip"]
    np.testing.assert_array_equal(sets["TipFace"], tip)  # the face x = L of element 4
    np.testing.assert_array_equal(sets["ENDS"], tip)
    bottom = np.flatnonzero((mesh.points[:, 2] < 1e-12) & (mesh.points[:, 0] < 0.1 + 1e-12))
    np.testing.assert_array_equal(sets["BOTTOM"], bottom)  # z = 0 under elements 1 and 2


def test_a_surface_face_a_solid_lacks_is_one_line(tmp_path):
    path, _, _ = _deck(tmp_path, "*SURFACE, NAME=S\n1, SPOS\n")
    with pytest.raises(MeshImportError, match="solid element faces are S1-S6"):
        import_mesh(path)


def _pie(sectors: int, copies: int, rings: int = 2, per_sector: int = 2,
         radius: float = 0.1, width: float = 0.02) -> Mesh:
    """``copies`` sectors of a disk through its axis (wedges round the axis, hexahedra
    outside; one layer): a sector (copies = 1, theta in [-phi/2, phi/2], cyclic faces
    paired, the axis nodes on both) or the whole disk (copies = sectors, closed)."""
    phi = 2 * np.pi / sectors
    nt = per_sector * copies
    whole = copies == sectors
    columns = nt if whole else nt + 1
    theta = -phi / 2 + phi / per_sector * np.arange(columns)
    r = radius * np.arange(1, rings + 1) / rings
    points, index = [], {}
    for k, z in enumerate((0.0, width)):
        index[("axis", k)] = len(points)
        points.append((0.0, 0.0, z))
        for i in range(rings):
            for j in range(columns):
                index[(i, j, k)] = len(points)
                points.append((r[i] * np.cos(theta[j]), r[i] * np.sin(theta[j]), z))

    def node(i, j, k):
        return index[("axis", k)] if i < 0 else index[(i, j % columns, k)]

    wedges, hexes = [], []
    for j in range(nt):
        wedges.append([node(-1, j, k) if c == 0 else node(0, j + c - 1, k)
                       for k in (0, 1) for c in (0, 1, 2)])
        for i in range(rings - 1):
            hexes.append([node(a, b, k) for k in (0, 1)
                          for a, b in ((i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1))])
    rim = np.array(sorted(node(rings - 1, j, k) for j in range(columns) for k in (0, 1)))
    cyclic_faces = {}
    if not whole:
        left = [node(i, 0, k) for k in (0, 1) for i in range(-1, rings)]
        right = [node(i, nt, k) if i >= 0 else node(-1, 0, k) for k in (0, 1)
                 for i in range(-1, rings)]
        cyclic_faces = {"disk": CyclicBoundary(left, right, sectors)}
    cells = len(wedges) + len(hexes)
    return Mesh("pie", np.array(points), np.empty((0, 4), np.int64),
                {"disk": np.arange(cells)}, node_sets={"disk/rim": rim},
                cyclic=cyclic_faces, hexahedra=np.array(hexes), wedges=np.array(wedges))


@pytest.mark.parametrize("sectors", [5, 6])
def test_a_sector_through_the_axis_is_its_whole_disk(sectors):
    """The axis nodes (and the edges along the axis) on both cyclic faces, each its own
    image: at ND h they keep what u = exp(i h phi) R(phi) u leaves (the axial motion at ND 0,
    the circular in-plane motion at ND 1, nothing beyond). The sector's spectra over every
    ND are the whole disk's, an odd and an even sector count."""
    sector, disk = _pie(sectors, 1), _pie(sectors, sectors)
    body = fem.assemble(sector, "disk", STEEL)
    found = []
    for h in range(sectors // 2 + 1):
        model = cyclic.sector_model(body, sector.node_sets["disk/rim"],
                                    sector.cyclic["disk"], h)
        lam = _eigenvalues(model.stiffness, model.mass)
        found += list(lam) * (1 if h in (0, sectors / 2) else 2)  # +-h: a pair
    whole = fem.assemble(disk, "disk", STEEL)
    full = cyclic.sector_model(whole, disk.node_sets["disk/rim"])
    expected = _eigenvalues(full.stiffness, full.mass)
    assert len(found) == len(expected)
    np.testing.assert_allclose(np.sort(found), expected, rtol=1e-8)


def test_a_deck_of_a_sector_through_the_axis_finds_its_faces(tmp_path):
    """Imported with [geometry.sector] only: the faces found on their planes, the axis nodes
    on both, and the same spectra as the sector built here."""
    from exports import write

    from microslip.geometry.sector import SectorSpec

    sector = _pie(6, 1)
    bare = Mesh("pie", sector.points, sector.tetrahedra, sector.bodies,
                node_sets=sector.node_sets, hexahedra=sector.hexahedra, wedges=sector.wedges)
    read = import_mesh(write(bare, tmp_path / "pie.inp"), bodies={"disk": "disk"},
                       sector=SectorSpec(6)).mesh
    faces = read.cyclic["disk"]
    on_axis = np.hypot(*read.points[:, :2].T) < 1e-12
    assert on_axis.sum() == 2 and set(np.flatnonzero(on_axis)) <= set(faces.left) & set(
        faces.right)
    spectra = []
    for mesh in (sector, read):
        body = fem.assemble(mesh, "disk", STEEL)
        rim = np.flatnonzero(np.hypot(*mesh.points[:, :2].T) > 0.1 - 1e-9)
        spectra.append(np.concatenate([_eigenvalues(m.stiffness, m.mass) for m in (
            cyclic.sector_model(body, rim, mesh.cyclic["disk"], h) for h in range(4))]))
    np.testing.assert_allclose(np.sort(spectra[1]), np.sort(spectra[0]), rtol=1e-9)


def _with_cards(path, cards: str, before: str | None = None):
    """The deck at ``path`` with ``cards`` added (before the line starting ``before``)."""
    text = path.read_text()
    at = text.find(f"\n{before}") + 1 if before and f"\n{before}" in text else len(text)
    path.write_text(text[:at] + cards + text[at:])
    return path


@pytest.mark.parametrize("suffix", [".bdf", ".cdb"])
def test_nastran_spc_and_ansys_d_are_supports(tmp_path, suffix):
    from exports import write

    mesh = block("hexahedron", (0.2, 0.02, 0.02), (4, 1, 1))
    clamp = mesh.node_sets["block/clamp"] + 1  # the writers number nodes from 1
    bodies = {"block": {".bdf": "pid1", ".cdb": "mat1"}[suffix]}
    path = write(mesh, tmp_path / f"deck{suffix}")
    if suffix == ".bdf":
        ids = ",".join(str(i) for i in clamp)
        cards = f"SPC1,1,12,{ids}\nSPC,1,{clamp[0]},3,0.0\n"
        _with_cards(path, cards, "ENDDATA")
    else:
        cards = "".join(f"D,{i},UX,0.0\nD,{i},UY,0.0\n" for i in clamp) + f"D,{clamp[0]},UZ,0\n"
        _with_cards(path, cards)
    supports = import_mesh(path, bodies=bodies).mesh.supports
    found = {tuple(s.held.tolist()): set(s.nodes.tolist()) for s in supports.values()}
    corner = int(clamp[0]) - 1
    assert found == {(True, True, False): set(mesh.node_sets["block/clamp"].tolist()) - {corner},
                     (True, True, True): {corner}}


@pytest.mark.parametrize(("suffix", "cards", "words"), [
    (".bdf", "SPC,1,1,1,0.5\n", "a non-zero displacement is a load"),
    (".bdf", "SPCD,1,1,1,0.5\n", "a prescribed displacement is a load"),
    (".cdb", "D,1,UX,0.5\n", "a non-zero displacement is a load"),
    (".cdb", "D,1,TEMP,0.0\n", "only UX, UY, UZ, ALL"),
])
def test_a_deck_support_that_is_a_load_is_one_line(tmp_path, suffix, cards, words):
    from exports import write

    path = write(block("hexahedron", (0.2, 0.02, 0.02), (4, 1, 1)), tmp_path / f"d{suffix}")
    _with_cards(path, cards, "ENDDATA" if suffix == ".bdf" else None)
    with pytest.raises(MeshImportError) as err:
        import_mesh(path, bodies={"block": {".bdf": "pid1", ".cdb": "mat1"}[suffix]})
    assert words in str(err.value) and "\n" not in str(err.value)


def test_ansys_material_cards_in_each_form_a_tool_writes(tmp_path):
    """MPDATA as CDWRITE writes it, as Workbench writes it (UNBL) and as typed."""
    from microslip.geometry import materials

    path = tmp_path / "m.cdb"
    path.write_text("MPTEMP,R5.0, 1, 1,  0.00000000    ,\n"
                    "MPDATA,R5.0, 1,EX  ,       1, 1,  2.1E+11    ,\n"
                    "MPDATA,R5.0, 1,PRXY,       1, 1, 0.3,\n"
                    "MPDATA,UNBL,16,DENS,2,1,7850.0\n"
                    "MPDATA,UNBL,16,EX,2,1,7.0E+10\n"
                    "MPDATA,UNBL,16,NUXY,2,1,0.33\n"
                    "MPDATA,DENS,1,,7800.\n")
    found = materials.ansys(path)
    assert found == {1: (2.1e11, 0.3, 7800.0), 2: (7.0e10, 0.33, 7850.0)}


def test_a_body_of_two_materials_is_assembled_element_by_element(tmp_path):
    """An Abaqus part of steel and aluminium elements sharing nodes: one body of two
    materials from the deck's cards; its mass is each zone's volume times its density, its
    stiffness each element's, against the two halves assembled on their own and summed
    (elements carry their own stiffness; the shared nodes add)."""
    from microslip.case.reduction_table import _resolved

    cards = ("*ELSET, ELSET=STEEL\n1, 2\n*ELSET, ELSET=ALU\n3, 4\n"
             "*MATERIAL, NAME=S\n*ELASTIC, TYPE=ISO\n2.0e11, 0.3\n*DENSITY\n7850.\n"
             "*MATERIAL, NAME=A\n*ELASTIC\n7.0e10, 0.33\n*DENSITY\n2700.\n"
             "*SOLID SECTION, ELSET=STEEL, MATERIAL=S\n*SOLID SECTION, ELSET=ALU, MATERIAL=A\n")
    path, _, _ = _deck(tmp_path, cards)
    read = import_mesh(path, bodies={"block": "BLOCK"}).mesh
    material = _resolved("file", read, "block")
    assert isinstance(material, fem.MaterialZones) and len(material.zones) == 2
    body = fem.assemble(read, "block", material, order=1)
    steel, alu = fem.Material(2.0e11, 0.3, 7850.0), fem.Material(7.0e10, 0.33, 2700.0)
    # element by element: each half assembled as a mesh of its own, scattered by node
    expected = np.zeros(body.stiffness.shape)
    for rows, m in (([0, 1], steel), ([2, 3], alu)):
        part = Mesh("part", read.points, read.tetrahedra, {"block": np.arange(2)},
                    hexahedra=read.hexahedra[rows])
        half = fem.assemble(part, "block", m, order=1)
        at = body.dofs_of_nodes(half.nodes).ravel()
        expected[np.ix_(at, at)] += half.stiffness.toarray()[np.ix_(
            half.node_dofs.ravel(), half.node_dofs.ravel())]
    np.testing.assert_allclose(body.stiffness.toarray(), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())
    whole = fem.assemble(read, "block", steel, order=1)
    volume = 0.2 * 0.02 * 0.02 / 2
    assert body.mass.sum() / 3 == pytest.approx(volume * (7850.0 + 2700.0), rel=1e-12)
    assert whole.mass.sum() / 3 == pytest.approx(2 * volume * 7850.0, rel=1e-12)
