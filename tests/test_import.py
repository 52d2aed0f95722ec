"""Meshes from other tools: the shipped parametric models written to .inp, .bdf and .msh (in
another frame and unit, linear and quadratic) read back as the same mesh and the same
matrices; units; sets chosen by geometry; cyclic faces found and paired; every bad file one
line, exit 2."""

import contextlib
import dataclasses
import io

import h5py
import meshio
import numpy as np
import pytest
from exports import write

from microslip import geometry
from microslip.cli import main
from microslip.fe import fem
from microslip.geometry.imported import UNITS, MeshImportError, Selection, import_mesh
from microslip.geometry.sector import SectorSpec, sector_frame
from microslip.geometry.structured import block

STEEL = fem.Material(2.0e11, 0.3, 7850.0)
AXIS = np.array([1.0, 0.2, -0.3]) / np.linalg.norm([1.0, 0.2, -0.3])
ORIGIN = np.array([10.0, -5.0, 2.0]) * 1e-3  # [m]: the axis passes here in the file


@pytest.fixture(scope="module")
def blisk():
    return geometry.blisk_sector()


@pytest.fixture(scope="module")
def blisk_body(blisk):
    return fem.assemble(blisk, "blisk", STEEL)


def _moved(mesh, path, **kw):
    """``mesh`` written with its axis on AXIS through ORIGIN, in millimetres."""
    rotation = sector_frame(AXIS, (0, 0, 0))[0].T  # takes +z to AXIS
    return write(mesh, path, scale=1e-3, rotation=rotation, origin=ORIGIN, **kw)


def _straight(mesh):
    """The mesh with straight edges (what a linear file keeps of it)."""
    return dataclasses.replace(mesh, curved_edges=np.empty((0, 2), np.int64),
                               edge_nodes=np.empty((0, 3)))


def _sector(mesh):
    return SectorSpec(mesh.cyclic["blisk"].sectors, tuple(AXIS), tuple(ORIGIN))


# (suffix, quadratic, bodies, coordinate agreement [m]): .inp and .msh keep 17 digits; the
# .bdf large field 11 (1e-11 relative of 0.3 m), see exports.write; the .cdb 13
FORMATS = [(".inp", True, None, 1e-15), (".msh", False, None, 1e-15),
           (".bdf", True, {"blisk": "pid1", "damper": "pid2"}, 1e-11),
           (".cdb", True, {"blisk": "mat1", "damper": "mat2"}, 1e-12)]


@pytest.mark.parametrize(("suffix", "quadratic", "bodies", "tol"), FORMATS)
def test_round_trip_gives_the_native_mesh_and_matrices(blisk, blisk_body, tmp_path, suffix,
                                                       quadratic, bodies, tol):
    path = _moved(blisk, tmp_path / f"blisk{suffix}", quadratic=quadratic)
    read = import_mesh(path, "mm-t-s", bodies, _sector(blisk))
    mesh = read.mesh
    # moved back into the contract's frame: the same nodes, elements, cyclic pairs
    assert np.abs(mesh.points - blisk.points).max() < tol
    np.testing.assert_array_equal(mesh.tetrahedra, blisk.tetrahedra)
    assert sorted(mesh.bodies) == ["blisk", "damper"]
    for name in blisk.bodies:
        np.testing.assert_array_equal(mesh.bodies[name], blisk.bodies[name])
    np.testing.assert_array_equal(mesh.cyclic["blisk"].left, blisk.cyclic["blisk"].left)
    np.testing.assert_array_equal(mesh.cyclic["blisk"].right, blisk.cyclic["blisk"].right)
    assert "damper" not in mesh.cyclic  # found by geometry: it has no cyclic faces
    renamed = {".bdf": None, ".cdb": lambda n: n.replace("/", "_").upper()}.get(
        suffix, lambda n: n)  # Nastran has no named node sets; Ansys names are capitals
    for name, nodes in blisk.node_sets.items() if renamed else ():
        np.testing.assert_array_equal(mesh.node_sets[renamed(name)], nodes)
    # the mid nodes where the model has them (Gmsh's, on its arcs), to the written digits;
    # a linear file has none: its edges are straight
    if quadratic:
        np.testing.assert_array_equal(mesh.curved_edges, blisk.curved_edges)
        assert np.abs(mesh.edge_nodes - blisk.edge_nodes).max() < tol
    else:
        assert len(mesh.curved_edges) == 0 and read.report.midnode_offset == 0.0
    assert read.report.elements == {("tetra10" if quadratic else "tetra"): len(blisk.tetrahedra)}
    # the same K and M (hence frequencies): relative to their largest entry, 1e-12 from the
    # 17 digits, 3e-9 from the .bdf's 11 (measured 1.0e-9: the curved edges' mid nodes
    # carry them into the element map too)
    again = fem.assemble(mesh, "blisk", STEEL)
    native = blisk_body if quadratic else fem.assemble(_straight(blisk), "blisk", STEEL)
    for a, b in ((native.stiffness, again.stiffness), (native.mass, again.mass)):
        assert abs(a - b).max() <= (1e-12 if tol < 1e-14 else 3e-9) * abs(a).max()


@pytest.mark.parametrize("suffix", [".inp", ".bdf", ".msh", ".cdb"])
def test_hexahedra_and_wedges_round_trip(tmp_path, suffix):
    """A mixed hex20 / wedge15 block through each format (Nastran orders the mid nodes of its
    CHEXA and CPENTA otherwise than VTK: the importer does not depend on their order)."""
    native = block("hexahedron", cells=(4, 2, 2), distort=0.2, mixed=True)
    read = import_mesh(write(native, tmp_path / f"b{suffix}", quadratic=True), "SI")
    mesh = read.mesh
    assert read.report.midnode_offset < 1e-9
    assert mesh.element_summary() == native.element_summary()
    a = fem.assemble(native, "block", STEEL)
    b = fem.assemble(mesh, next(iter(mesh.bodies)), STEEL)
    order = np.argsort(np.linalg.norm(a.points - b.points[:, None], axis=2).argmin(axis=0))
    assert np.abs(b.points[order] - a.points).max() < 1e-10  # the same nodes
    # the same eigenvalues of the free-free block (K and M equal up to the DOF numbering):
    # 1e-9 relative, the six rigid-body zeros to 1e-9 of the largest
    lam = [_lowest(m) for m in (a, b)]
    np.testing.assert_allclose(lam[1], lam[0], rtol=1e-9, atol=1e-9 * lam[0][-1])


def _lowest(body, n=12):
    import scipy.linalg as sla

    return sla.eigh(body.stiffness.toarray(), body.mass.toarray(), eigvals_only=True,
                    subset_by_index=[0, n - 1])


def test_units():
    """The unit systems against their definitions (NIST SP 811): psi = 6894.757 Pa, the
    slinch/in^3 = 1.068690e7 kg/m^3; mm-t-s: N, MPa, t/mm^3 = 1e12 kg/m^3."""
    si, mts, mks, ips = (UNITS[k] for k in ("SI", "mm-t-s", "mm-kg-s", "in-lbf-s"))
    assert (si.force, si.stress, si.density) == (1.0, 1.0, 1.0)
    assert mts.force == pytest.approx(1.0) and mts.stress == pytest.approx(1e6)
    assert mts.density == pytest.approx(1e12)
    assert mks.force == pytest.approx(1e-3) and mks.stress == pytest.approx(1e3)
    assert ips.force == pytest.approx(4.4482216152605, rel=1e-12)
    assert ips.stress == pytest.approx(6894.757293168, rel=1e-9)
    assert ips.density == pytest.approx(1.0686894e7, rel=1e-6)


def test_sets_chosen_by_geometry(blisk, tmp_path):
    """The bore of the .bdf (no named sets) chosen as the surface nodes on r = r_bore about
    the axis: the native 'blisk/bore'."""
    path = _moved(blisk, tmp_path / "b.bdf")
    sets = {"bore": Selection(radius=0.10, tolerance=1e-7, body="blisk")}
    mesh = import_mesh(path, "mm-t-s", {"blisk": "pid1", "damper": "pid2"}, _sector(blisk),
                       sets).mesh
    np.testing.assert_array_equal(mesh.node_sets["bore"], blisk.node_sets["blisk/bore"])
    with pytest.raises(MeshImportError, match="selects no surface node"):
        import_mesh(path, "mm-t-s", None, _sector(blisk),
                    {"x": Selection(radius=0.5, tolerance=1e-7)})


def test_cyclic_faces_by_name_and_mismatch(blisk, tmp_path):
    path = _moved(blisk, tmp_path / "b.inp")
    given = SectorSpec(48, tuple(AXIS), tuple(ORIGIN),
                       (("blisk", "cyclic/blisk/right", "cyclic/blisk/left"),))  # swapped
    mesh = import_mesh(path, "mm-t-s", None, given).mesh
    np.testing.assert_array_equal(mesh.cyclic["blisk"].left, blisk.cyclic["blisk"].left)
    wrong = SectorSpec(47, tuple(AXIS), tuple(ORIGIN),
                       (("blisk", "cyclic/blisk/left", "cyclic/blisk/right"),))
    with pytest.raises(MeshImportError, match=r"geometry.sector.faces.blisk: .*worst distance"):
        import_mesh(path, "mm-t-s", None, wrong)


def _gmsh_deck(path, order: int, hexahedra: bool):
    """A 1 x 0.2 x 0.1 m box meshed and written to .inp by Gmsh: physical volume BODY and
    surface FIX (x = 0), tetrahedra or (transfinite, recombined) serendipity hexahedra.
    Returns Gmsh's own view: node tag -> coordinates, and the solids' corner node tags."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        box = gmsh.model.occ.addBox(0, 0, 0, 1, 0.2, 0.1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(3, [box], name="BODY")
        faces = [f for _, f in gmsh.model.getBoundary([(3, box)], oriented=False)]
        fix = [f for f in faces if abs(gmsh.model.occ.getCenterOfMass(2, f)[0]) < 1e-9]
        gmsh.model.addPhysicalGroup(2, fix, name="FIX")
        if hexahedra:
            for _, tag in gmsh.model.getEntities(1):
                gmsh.model.mesh.setTransfiniteCurve(tag, 4)
            for _, tag in gmsh.model.getEntities(2):
                gmsh.model.mesh.setTransfiniteSurface(tag)
                gmsh.model.mesh.setRecombine(2, tag)
            gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.05)
        gmsh.option.setNumber("Mesh.ElementOrder", order)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)  # hexahedron20
        gmsh.option.setNumber("Mesh.SaveGroupsOfNodes", 1)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        (kind,), _, (nodes,) = gmsh.model.mesh.getElements(3)
        _, _, _, count, _, corners = gmsh.model.mesh.getElementProperties(kind)
    finally:
        gmsh.finalize()
    position = dict(zip(tags.tolist(), xyz.reshape(-1, 3), strict=True))
    return position, nodes.reshape(-1, count)[:, :corners]


@pytest.mark.parametrize(("order", "hexahedra"), [(1, False), (2, False), (1, True),
                                                   (2, True)])
def test_decks_gmsh_writes(tmp_path, order, hexahedra):
    """The deck reader on decks Gmsh writes (with its surface elements, and its entity
    ELSETs beside the physical ones) against Gmsh's own mesh: the same corner nodes and
    elements, the physical names, the box's volume."""
    position, corners = _gmsh_deck(tmp_path / "box.inp", order, hexahedra)
    read = import_mesh(tmp_path / "box.inp")
    mesh = read.mesh
    assert sorted(mesh.bodies) == ["BODY"]  # the physical name, not Gmsh's "Volume1"
    assert mesh.body_volume("BODY") == pytest.approx(0.02, rel=1e-12)
    np.testing.assert_array_equal(mesh.node_sets["FIX"],
                                  np.flatnonzero(np.abs(mesh.points[:, 0]) < 1e-12))
    assert read.report.midnode_offset < 1e-9
    assert sum(read.report.skipped.values()) > 0  # Gmsh's surface elements of FIX
    cells = mesh.hexahedra if hexahedra else mesh.tetrahedra
    assert len(cells) == len(corners)
    ours = {tuple(sorted(map(tuple, np.round(mesh.points[c], 12)))) for c in cells}
    theirs = {tuple(sorted(tuple(np.round(position[t], 12)) for t in c)) for c in corners}
    assert ours == theirs  # every element, by its corners' positions


def _check(tmp_path, geometry_table: str, masters: str = '"block/tip"'):
    """``microslip check`` of a case importing a mesh: (exit code, what it printed)."""
    case = tmp_path / "case.toml"
    case.write_text(f'title = "t"\n[reduction]\n[reduction.bodies.block]\nmasters = [{masters}]\n'
                    f'[geometry]\nmodel = "import"\n{geometry_table}\n')
    return _check_file(case)


def test_bad_files_are_one_line_exit_2(tmp_path):
    good = write(block("hexahedron", cells=(2, 1, 1)), tmp_path / "good.inp")
    text = good.read_text()
    (tmp_path / "cut.inp").write_text(text[: len(text) // 2])
    flipped = block("wedge", cells=(2, 1, 1))
    pyramid = meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0]]),
                          [("pyramid", np.array([[0, 1, 2, 3, 4]]))])
    meshio.write(tmp_path / "pyramid.msh", pyramid, file_format="gmsh22", binary=False)
    (tmp_path / "shell.inp").write_text(text.replace("TYPE=C3D8RH", "TYPE=S4R"))
    (tmp_path / "c3d5.inp").write_text(text.replace("TYPE=C3D8RH", "TYPE=C3D5"))
    w = flipped.wedges.copy()
    w[1] = w[1][[0, 2, 1, 3, 5, 4]]
    meshio.write(tmp_path / "flip.inp", meshio.Mesh(flipped.points, [("wedge", w)]))
    (tmp_path / "noise.msh").write_bytes(bytes(range(256)) * 4)
    cases = {
        'file = "missing.inp"': "missing.inp': no such file",
        'file = "cut.inp"': "cut.inp",
        'file = "pyramid.msh"': "element type(s) ['pyramid'] not supported",
        'file = "shell.inp"': "no solid elements",  # shells are skipped, not read
        'file = "c3d5.inp"': "element type C3D5 not supported",
        'file = "flip.inp"': "1 wedge element(s) inverted or tangled",
        'file = "noise.msh"': "not a readable mesh",
        'file = "good.inp"\nunits = "cm"': "geometry.units = 'cm': expected one of",
        'file = "good.inp"\n[geometry.sector]\nsectors = 12':
            "geometry.sector: no body of",
    }
    for table, message in cases.items():
        code, said = _check(tmp_path, table)
        assert code == 2, (table, said)
        assert message in said, (table, said)
        assert len(said.strip().splitlines()) == 1, said  # one fault, one line
    code, said = _check(tmp_path, 'file = "good.inp"\nbodies = {block = "block"}')
    assert code == 0, said
    code, said = _check(tmp_path, 'file = "good.inp"', '"nope"')
    assert code == 2 and "node set 'nope' does not exist" in said


@pytest.mark.slow
@pytest.mark.parametrize(("suffix", "quadratic", "bodies", "tol"),
                         [f for f in FORMATS if f[0] != ".bdf"])  # (no sets to name masters)
def test_round_trip_gives_the_native_reduced_frequencies(blisk, tmp_path, suffix, quadratic,
                                                         bodies, tol):
    """The blisk case reduced (Craig-Bampton, NDs 0 and 3) from its own mesh and from the
    file read back, as `microslip run` does it: the same frequencies per body and ND, to 1e-9
    (the damper's six rigid-body zeros to 1e-6 of its highest, their round-off)."""
    from microslip.app.run import run_case
    from microslip.case import load

    # quadratic in every format: the native model's mid nodes are on its arcs
    path = _moved(blisk, tmp_path / f"blisk{suffix}", quadratic=True)
    named = {".cdb": lambda n: n.replace("/", "_").upper()}.get(suffix, lambda n: n)
    common = ("[reduction]\nnodal_diameters = [0, 3]\n[reduction.material]\n"
              "youngs_modulus = 2.0e11\npoisson_ratio = 0.3\ndensity = 7850.0\n")
    (tmp_path / "native.toml").write_text('[geometry]\nmodel = "blisk_sector"\n' + common)
    # the native masters (every patch node + excitation + response) and clamp, by set name
    masters = {"blisk": ["contact/damper_left/blisk", "contact/damper_right/blisk",
                         "blisk/excitation", "blisk/response"],
               "damper": ["contact/damper_left/damper", "contact/damper_right/damper"]}
    bodies_line = ("bodies = {" + ", ".join(f'{b} = "{g}"' for b, g in bodies.items())
                   + "}\n") if bodies else ""
    table = (f'[geometry]\nmodel = "import"\nfile = "{path.name}"\nunits = "mm-t-s"\n'
             f"{bodies_line}[geometry.sector]\nsectors = 48\naxis = {AXIS.tolist()}\n"
             f"origin = {ORIGIN.tolist()}\n{common}")
    for body, names in masters.items():
        table += (f"[reduction.bodies.{body}]\nmasters = "
                  + str([named(n) for n in names]).replace("'", '"') + "\n")
    (tmp_path / "imported.toml").write_text(
        table.replace("[reduction.bodies.blisk]\n",
                      f'[reduction.bodies.blisk]\nclamped = ["{named("blisk/bore")}"]\n'))
    out = {}
    for name in ("native", "imported"):
        result = run_case(load(tmp_path / f"{name}.toml"), tmp_path / name,
                          progress=lambda s: None)
        with h5py.File(result) as f:
            out[name] = {(b, h): f[f"reduction/{b}/nd{h}/frequencies_hz"][()]
                         for b in ("blisk", "damper") for h in (0, 3)}
    for key, f in out["native"].items():
        np.testing.assert_allclose(out["imported"][key], f, rtol=1e-9, atol=1e-6 * f.max())


def test_materials_from_the_file(tmp_path):
    """material = "file": each deck's cards in its units, read back in SI (210 GPa, 0.3,
    7850 kg/m^3 written in mm-t-s as 2.1e5 MPa, 0.3, 7.85e-9 t/mm^3), through `check` and
    the body specs; a body without cards, and "file" with a parametric model, refused."""
    from microslip.case import load
    from microslip.case.reduction_table import body_specs

    mesh = block("hexahedron", cells=(4, 1, 1))
    deck = write(mesh, tmp_path / "b.inp")
    deck.write_text(deck.read_text() + "*MATERIAL, NAME=STEEL\n*ELASTIC\n210000., 0.3\n"
                    "*DENSITY\n7.85e-9,\n*SOLID SECTION, ELSET=block, MATERIAL=STEEL\n")
    nastran = write(mesh, tmp_path / "b.bdf")  # free and small-field cards, Nastran reals
    nastran.write_text(nastran.read_text().replace(
        "ENDDATA", "MAT1,7,2.1+5,,.3,7.85-9\nPSOLID  1       7\nENDDATA"))
    ansys = write(mesh, tmp_path / "b.cdb")  # CDWRITE's MPDATA lines
    ansys.write_text(ansys.read_text() + "".join(
        f"MPDATA,R5.0, 1,{label},       1, 1,  {value},\n"
        for label, value in (("EX  ", "2.10000000E+05"), ("PRXY", "0.300000000"),
                             ("DENS", "7.85000000E-09"))))
    steel = fem.Material(2.1e11, 0.3, 7850.0)
    for path, body in ((deck, "block"), (nastran, "pid1"), (ansys, "mat1")):
        case = tmp_path / f"{path.suffix[1:]}.toml"
        case.write_text(f'[geometry]\nmodel = "import"\nfile = "{path.name}"\n'
                        'units = "mm-t-s"\n[reduction]\nmaterial = "file"\n'
                        f'[reduction.bodies.{body}]\nmasters = ["{_tip(path)}"]\n')
        loaded = load(case)
        (spec,) = body_specs(loaded.geometry_table.build(), loaded.reduction_table)
        got = spec.material
        assert (got.youngs_modulus, got.poisson_ratio, got.density) == pytest.approx(
            (steel.youngs_modulus, steel.poisson_ratio, steel.density), rel=1e-12), path
    write(mesh, tmp_path / "bare.inp")  # no cards
    (tmp_path / "bare.toml").write_text(
        '[geometry]\nmodel = "import"\nfile = "bare.inp"\n[reduction]\nmaterial = "file"\n'
        '[reduction.bodies.block]\nmasters = ["block/tip"]\n')
    code, said = _check_file(tmp_path / "bare.toml")
    assert code == 2 and "body 'block', but its elements have no material" in said
    (tmp_path / "param.toml").write_text(
        '[geometry]\nmodel = "beam"\n[reduction]\nmaterial = "file"\n')
    code, said = _check_file(tmp_path / "param.toml")
    assert code == 2 and 'reduction.material = "file": only an imported mesh' in said


def _tip(path):
    """The tip set's name as each format keeps it (Nastran: none, so a clamp-free body's
    masters are chosen as the Ansys components are named)."""
    return {".cdb": "BLOCK_TIP", ".bdf": "pid1"}.get(path.suffix, "block/tip")


def _check_file(case):
    """``microslip check CASE``: (exit code, what it printed)."""
    said = io.StringIO()
    with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
        code = main(["check", str(case)])
    return code, said.getvalue()


def test_deck_rules(tmp_path):
    """Abaqus rules the deck reader keeps: names case-insensitive (two spellings of a set are
    one set; a section names its set and material in another case), a solid's node list
    running over lines by its count, a list cut short refused, a set of mid-side nodes only
    named as such."""
    from microslip.geometry import abaqus

    nodes = "*NODE\n1, 0,0,0\n2, 1,0,0\n3, 0,1,0\n4, 0,0,1\n5, 1,1,1\n"
    deck = tmp_path / "a.inp"
    deck.write_text(nodes + "*ELEMENT, TYPE=C3D4, ELSET=Eall\n1, 1,2,3,4\n"
                    "*ELEMENT, TYPE=C3D4, ELSET=EALL\n2, 2,3,4,\n5\n"
                    "*MATERIAL, NAME=Steel\n*ELASTIC\n210000, 0.3\n*DENSITY\n7.85e-9\n"
                    "*SOLID SECTION, ELSET=eall, MATERIAL=STEEL\n*NSET, NSET=fix\n1, 2\n"
                    "*NSET, NSET=FIX\n3\n")
    raw = abaqus.read(deck)
    assert list(raw.cell_sets) == ["Eall"] and [len(b) for b in raw.cell_sets["Eall"]] == [1, 1]
    assert raw.point_sets["fix"].tolist() == [0, 1, 2]
    mesh = import_mesh(deck, "mm-t-s").mesh
    assert mesh.parameters["materials"]["Eall"]["youngs_modulus"] == pytest.approx(2.1e11)
    cut = tmp_path / "cut.inp"
    cut.write_text(nodes + "*ELEMENT, TYPE=C3D4\n1, 1,2,3,\n*ELEMENT, TYPE=C3D4\n2, 1,2,3,4\n")
    with pytest.raises(MeshImportError, match="element 1 has 3 nodes before the next keyword"):
        import_mesh(cut)
    quadratic = write(block("tetra", cells=(1, 1, 1)), tmp_path / "q.inp", quadratic=True)
    text = quadratic.read_text()
    first_mid = len(block("tetra", cells=(1, 1, 1)).points) + 1  # mid nodes follow corners
    quadratic.write_text(text + f"*NSET, NSET=MIDDLE\n{first_mid}\n")
    read = import_mesh(quadratic)
    assert read.report.dropped_sets == ("MIDDLE",)
    with pytest.raises(ValueError, match="holds mid-side nodes only"):
        fem.node_set(read.mesh, "MIDDLE")


# The shipped models with contacts, coarse: (parameters, the spec's loads / output / extras
# by body, the interference); the ND 1 family's first frequency is where the FRF points sit.
MODELS = {
    "blisk_sector": (dict(sectors=6, size=0.03, blade_size=0.012, contact_n_axial=3,
                          contact_n_flank=2),
                     ("blisk", 200.0, dict(speed=1000.0, centrifugal=("damper",),
                                           mass_bodies=("damper",))), 0.0),
    "root_joint": (dict(size=0.02, blade_size=0.008, contact_n_axial=3, contact_n_flank=2),
                   ("blade", 20.0, dict(speed=1000.0, centrifugal=("blade",))), 0.0),
    "shrouded_blisk": (dict(sectors=24, size=0.02, blade_size=0.008),
                       ("blisk", 30.0, {}), 2e-5),
}


def _declared(native, read, named):
    """The native patches as contacts between the file's node sets: each patch's two sets
    (side a the one holding nodes_a), the neighbour's where the patch has an offset, the
    stiffness shared equally as a structured patch shares it."""
    from microslip.geometry.pairing import declare_contact

    out = {}
    for name, p in native.contacts.items():
        sets = [s for s in native.node_sets if s.startswith(f"contact/{name}/")]
        sets.sort(key=lambda s: not np.array_equal(np.sort(native.node_sets[s]),
                                                   np.sort(p.nodes_a.ravel())))
        out[name] = declare_contact(read, name, tuple(named(s) for s in sets),
                                    neighbour=bool(p.b_sector_offset), spread="nodes")
        assert (out[name].body_a, out[name].b_sector_offset) == (p.body_a, p.b_sector_offset)
    return out


# (.bdf: Nastran has no node sets to name the contacts' surfaces; its matrices and reduced
# frequencies are checked above)
@pytest.mark.parametrize("model", [pytest.param(m, marks=() if m == "blisk_sector" else
                                                pytest.mark.slow) for m in MODELS])
@pytest.mark.parametrize(("suffix", "quadratic", "bodies", "tol"), [
    FORMATS[0], *(pytest.param(*f, marks=pytest.mark.slow) for f in FORMATS[1:]
                  if f[0] != ".bdf")])
def test_round_trip_gives_the_native_frf(tmp_path, model, suffix, quadratic, bodies, tol):
    """Each model with contacts written in another frame and unit, read back with its
    contacts declared between the file's node sets (a neighbour's face by neighbour = true,
    the stiffness shared equally as the model's patches do), reduced and joined: the same
    FRF points as the native model (on the blisk with stick, slip and lift-off along the
    damper flanks), to what the reduction's eigen-solves leave (below)."""
    import dataclasses

    from microslip.app import structure
    from microslip.assembly.join import join
    from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
    from microslip.fourier import Harmonics
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import solve_point

    parameters, (loaded, force, extras), interference = MODELS[model]
    native = geometry.MODELS[model](**parameters)
    (cyclic_body,) = native.cyclic
    path = _moved(native, tmp_path / f"{model}{suffix}", quadratic=True)  # its arcs too
    sector = SectorSpec(native.cyclic[cyclic_body].sectors, tuple(AXIS), tuple(ORIGIN))
    groups = None if bodies is None else {b: f"mat{k + 1}" for k, b in enumerate(native.bodies)}
    read = import_mesh(path, "mm-t-s", groups, sector).mesh
    named = {".cdb": lambda n: n.replace("/", "_").upper()}.get(suffix, lambda n: n)
    read = dataclasses.replace(read, contacts=_declared(native, read, named))
    frf = {}
    for name, mesh, nm in (("native", native, lambda n: n), ("read", read, named)):
        clamp = next(s for s in native.node_sets if s.endswith("/bore"))
        tables = {clamp.split("/")[0]: {"clamped": [nm(clamp)]}}
        tables.setdefault(loaded, {})["masters"] = [nm(f"{loaded}/excitation"),
                                                    nm(f"{loaded}/response")]
        red = {"modes": "auto", "f_max": 1500.0, "order": 1, "nodal_diameters": [0, 1],
               "damping": {"modal_ratios": 0.005}, "bodies": tables}
        st = structure.reduce_structure(mesh, red, None, progress=lambda s: None)
        spec = AssemblySpec(
            contacts=tuple(PatchFriction(p, 0.5, interference) for p in sorted(mesh.contacts)),
            engine_order=1, loads=(NodalLoad(nm(f"{loaded}/excitation"), "tangential", force),),
            outputs=(Output("tip", nm(f"{loaded}/response"), "tangential"),), **extras)
        cm = join(mesh, st.models, st.patch_stiffness, spec, Harmonics.up_to(1, 64))
        w1 = 2 * np.pi * st.frequencies[cyclic_body, 1][0]
        out, states = [], set()
        for w in w1 * np.array([0.97, 1.0, 1.03]):
            r = solve_point(cm.hb, OperatingPoint(w))
            assert r.converged, r.reason
            out.append(cm.output_coefficients(r.x, OperatingPoint(w))[0])
            states |= {int(s) for c in cm.hb.contact_response(r.x, OperatingPoint(w))
                       for s in c.state}
        frf[name] = np.array(out)
    if model == "blisk_sector":
        assert len(states) >= 2, states  # not a linear limit
    # The reduced models agree to the eigen-solver's tolerance (1e-10 in frequency), which
    # the resonance amplifies by its quality factor, 1 / (2 zeta) = 100, and Newton stops at
    # 1e-9 of the forces: measured 3-6e-10 (blisk), 2e-9 to 1.3e-8 (root joint), 6-7e-11
    # (shroud) of the largest coefficient
    error = np.abs(frf["read"] - frf["native"]).max() / np.abs(frf["native"]).max()
    assert error < 1e-7


# every shipped model, coarse (the blisk and the contact models as in MODELS)
COARSE_MODELS = {"annular_sector": dict(size=0.03), "beam": {},
                 **{m: p for m, (p, _, _) in MODELS.items()}}


@pytest.mark.parametrize("suffix", [".inp", *(pytest.param(s, marks=pytest.mark.slow)
                                              for s in (".msh", ".cdb", ".bdf"))])
@pytest.mark.parametrize("model", sorted(COARSE_MODELS))
def test_every_model_reads_back_to_the_same_matrices(tmp_path, model, suffix):
    """Each shipped parametric model written in millimetres (a sector in another frame too)
    and read back: every body's K and M (linear elements) equal to 1e-10 of their largest
    entry, so the reduced frequencies too (measured up to 9e-12: 17 digits, then the
    frame's rotation and scale in round-off; the .bdf's large field keeps 11 digits: 1e-8)."""
    native = geometry.MODELS[model](**COARSE_MODELS[model])
    cyc = next(iter(native.cyclic.values()), None)
    if cyc is None:  # quadratic: the mid nodes Gmsh curved on the arcs go with it
        path = write(native, tmp_path / f"{model}{suffix}", scale=1e-3, quadratic=True)
        sector = None
    else:
        path = _moved(native, tmp_path / f"{model}{suffix}", quadratic=True)
        sector = SectorSpec(cyc.sectors, tuple(AXIS), tuple(ORIGIN))
    prefix = {".bdf": "pid", ".cdb": "mat"}.get(suffix)
    groups = None if prefix is None else {b: f"{prefix}{k + 1}"
                                          for k, b in enumerate(native.bodies)}
    read = import_mesh(path, "mm-t-s", groups, sector).mesh
    assert sorted(read.bodies) == sorted(native.bodies)
    tol = 1e-8 if suffix == ".bdf" else 1e-10
    for body in native.bodies:
        a, b = (fem.assemble(m, body, STEEL, order=1) for m in (native, read))
        for x, y in ((a.stiffness, b.stiffness), (a.mass, b.mass)):
            assert abs(x - y).max() <= tol * abs(x).max(), (body, abs(x - y).max())
