"""The shrouded blisk sector (geometry.shroud): its interlock faces meet the neighbour's node
for node, the mesh is valid and periodic, its parameters are checked before Gmsh runs, and
its reduced model keeps both interlock faces as masters."""

import numpy as np
import pytest
import scipy.sparse.linalg as spl

from microslip import geometry
from microslip.fe import bodies, cyclic, fem
from microslip.geometry import GeometryParameterError, rotation_z
from microslip.geometry.quality import sicn
from microslip.geometry.shroud import ShroudParameters


@pytest.fixture(scope="module")
def shroud():
    return geometry.shrouded_blisk()


def test_interlock_faces_meet_the_neighbours(shroud):
    """Side a (the interlock at +phi/2) is side b's image in the next sector, node for node;
    the patch is the interlock rectangle (thickness x notch length / cos(angle)); the normal
    points into the neighbour (tangentially +, along the notch)."""
    p = ShroudParameters()
    patch = shroud.contacts["shroud"]
    assert patch.body_a == patch.body_b == "blisk" and patch.b_sector_offset == 1
    a, b = shroud.points[patch.nodes_a], shroud.points[patch.nodes_b]
    np.testing.assert_allclose(a, b @ rotation_z(p.phi).T, atol=1e-12)
    length = p.notch_length / np.cos(np.radians(p.notch_angle))
    assert patch.area == pytest.approx(p.shroud_thickness * length, rel=1e-12)
    tangent = np.array([-np.sin(p.phi / 2), np.cos(p.phi / 2), 0.0])
    assert patch.normal @ tangent == pytest.approx(np.cos(np.radians(p.notch_angle)))
    assert shroud.contacts["shroud"].shape == (p.contact_n_radial, p.contact_n_along)


def test_mesh_quality_names_and_volume(shroud):
    assert sicn(shroud.points, shroud.tetrahedra).min() > 0.1
    names = geometry.NAMES["shrouded_blisk"]
    assert set(names["bodies"]) == set(shroud.bodies)
    assert set(names["patches"]) == set(shroud.contacts)
    assert set(names["node_sets"]) == set(shroud.node_sets)
    cad = shroud.parameters["derived"]["cad_volume"]["blisk"]
    # the bore and rim are cylinders: the tets' chords lose ~1e-4 of the volume
    assert shroud.body_volume("blisk") == pytest.approx(cad, rel=5e-3)


def test_parameters_are_checked_before_meshing():
    with pytest.raises(GeometryParameterError, match="notch_length"):
        geometry.shrouded_blisk(notch_length=0.05)
    with pytest.raises(GeometryParameterError, match="arm_clearance"):
        geometry.shrouded_blisk(arm_clearance=0.004)


def _spec():
    return bodies.BodySpec(body="blisk", material=fem.Material(2.0e11, 0.3, 7850.0),
                              patches=("shroud",), clamped_sets=("blisk/bore",),
                              master_sets=("blisk/excitation", "blisk/response"))


def test_both_interlock_faces_are_masters(shroud):
    """A body touching its own neighbour: both sides of its patch are its masters."""
    masters, _, _, _ = bodies.spec_nodes(shroud, _spec())
    patch = shroud.contacts["shroud"]
    assert np.isin(patch.nodes_a, masters).all() and np.isin(patch.nodes_b, masters).all()


@pytest.mark.slow
def test_reduced_model_matches_the_sector(shroud):
    """Craig-Bampton of the shrouded sector at ND 3 (both interlock faces masters, every
    fixed-interface mode below the cut-off): the first ten frequencies of the sector model
    within 0.1 %."""
    spec = _spec()
    body = fem.assemble(shroud, "blisk", spec.material)
    sector = cyclic.sector_model(body, shroud.node_sets["blisk/bore"], shroud.cyclic["blisk"], 3)
    lam = spl.eigsh(sector.stiffness.tocsc(), k=10, M=sector.mass.tocsc(), sigma=0,
                    return_eigenvectors=False)
    full = np.sqrt(np.sort(lam.real)) / (2 * np.pi)
    reduced = bodies.reduce_body(shroud, spec, (3,), None, None, lambda *a: None)[3]
    np.testing.assert_allclose(reduced.frequencies(10), full, rtol=1e-3)


@pytest.mark.slow  # ~3 min: the full disk's harmonic balance has 24 x 18 interlock pairs
def test_the_shroud_sector_equals_the_full_disk():
    """The interlock through the cyclic phase (a body touching its own next sector) against
    24 rotated copies of the sector joined node for node, their interlocks plain contacts of
    the one blisk body, loaded with the engine order's phase: first-harmonic tip amplitudes at
    the stuck resonance, stuck (measured 8e-9) and with stick-slip and partial lift-off at
    30 N (measured 1.3e-4: Newton stops at 1e-9 of the forces, and the interlock's forces
    are ~1e4 x the excitation there)."""
    from microslip.app import structure
    from microslip.assembly.join import join
    from microslip.assembly.spec import AssemblySpec, NodalLoad, Output, PatchFriction
    from microslip.fourier import Harmonics
    from microslip.solve.linear import OperatingPoint
    from microslip.solve.response import solve_point

    ns = 24  # (the model's blade and shroud part below ~20 blades)
    sector = geometry.shrouded_blisk(sectors=ns, size=0.02, blade_size=0.008)
    full = geometry.full_disk(sector)
    red = {"modes": "auto", "f_max": 3000.0, "order": 1, "damping": {"modal_ratios": 0.005}}
    sets = {s: [f"blisk/{s}#{k}" for k in range(ns)] for s in ("bore", "excitation",
                                                                "response")}
    st = structure.reduce_structure(sector, {**red, "nodal_diameters": [0, 1]}, None,
                                    progress=lambda s: None)
    st_full = structure.reduce_structure(full, {**red, "nodal_diameters": [0], "bodies": {
        "blisk": {"clamped": sets["bore"], "masters": sets["excitation"] + sets["response"],
                  "recovery": []}}}, None, progress=lambda s: None)
    h, phi = Harmonics.up_to(1, 64), 2 * np.pi / ns

    def models(mu, amplitude):
        out = Output("tip", "blisk/response", "tangential")
        cyc = join(sector, st.models, st.patch_stiffness, AssemblySpec(
            contacts=(PatchFriction("shroud", mu, 2e-5),), engine_order=1,
            loads=(NodalLoad("blisk/excitation", "tangential", amplitude),), outputs=(out,)),
            h)
        disk = join(full, st_full.models, st_full.patch_stiffness, AssemblySpec(
            contacts=tuple(PatchFriction(p, mu, 2e-5) for p in sorted(full.contacts)),
            engine_order=1, outputs=(Output("tip", "blisk/response#0", "tangential"),),
            loads=tuple(NodalLoad(f"blisk/excitation#{k}", "tangential", amplitude, 1,
                                  k * phi) for k in range(ns))), h)
        return cyc, disk

    def amplitude(cm, w):
        r = solve_point(cm.hb, OperatingPoint(w))
        assert r.converged, r.reason
        states = {int(s) for c in cm.hb.contact_response(r.x, OperatingPoint(w))
                  for s in c.state}
        return np.hypot(*cm.output_coefficients(r.x, OperatingPoint(w))[0, 1:3]), states

    cyc, disk = models(1e4, 1.0)
    ws = np.linspace(2000.0, 12000.0, 201)
    w0 = ws[np.argmax([np.hypot(*cyc.linear_outputs(OperatingPoint(w), "stuck")[0, 1:3])
                       for w in ws])]
    for (mu, force), tol in (((1e4, 1.0), 1e-7), ((0.5, 30.0), 1e-3)):
        cyc, disk = models(mu, force)
        (a, states), (b, _) = amplitude(cyc, w0), amplitude(disk, w0)
        assert abs(a / b - 1) < tol, (mu, force, a / b - 1)
    assert len(states) >= 2, states  # the second is not a linear limit
