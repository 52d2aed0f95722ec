"""An assembly case end to end: the [assembly] table checked before any meshing (one line per
fault), then mesh -> reduction -> assembly -> FRF with the linear limits, into results.h5."""

import copy
from pathlib import Path

import h5py
import numpy as np
import pytest
from case_helpers import case_faults
from vtk_layout import layout_faults

from microslip import case as cases
from microslip import geometry
from microslip.app.run import run_case
from microslip.case import GeometryTable
from microslip.cli import main

CASE = {
    "title": "coarse blisk assembly",
    "geometry": {"model": "blisk_sector", "parameters": {
        "sectors": 6, "size": 0.03, "blade_size": 0.012, "contact_n_axial": 3,
        "contact_n_flank": 2}},
    "reduction": {"engine_order": 1, "order": 1, "modes": "auto", "f_max": 1500.0,
                  "damping": {"modal_ratios": 0.005}},
    "harmonics": {"max": 1, "samples": 64},
    "assembly": {
        "speed": 1000.0, "centrifugal": ["damper"], "mass_multiplier": 2.0,
        "contacts": [{"patch": "damper_left", "mu": 0.5},
                     {"patch": "damper_right", "mu": 0.5, "elements": "1D+1D"}],
        "loads": [{"node_set": "blisk/excitation", "direction": "tangential",
                   "amplitude": 1.0}],
        "outputs": [{"name": "tip", "node_set": "blisk/response", "direction": "tangential"}],
    },
    "analysis": [{"name": "frf", "type": "frf", "start": 3200.0, "stop": 3300.0,
                  "outputs": ["tip"], "maps": ["peak", 3250.0],
                  "map_types": ["status", "normal_load", "shape"]}],
}


def faults(mutate) -> list[str]:
    return case_faults(CASE, mutate)


def test_a_geometry_fault_is_one_line_and_only_that():
    """The [reduction] of a case whose geometry has a fault says nothing of its symmetry
    (unknown until the geometry is right)."""
    found = faults(lambda d: d["geometry"]["parameters"].update(contact_n_axial=0))
    assert found == ["geometry.parameters.contact_n_axial = 0: must be an integer in [2, 500] "
                     "(contact points along the axis (n1))"]


def test_the_shipped_case_is_valid():
    cases.check(copy.deepcopy(CASE))
    assert main(["check", "cases/15_blisk_damper.toml"]) == 0


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d["assembly"]["contacts"][0].update(patch="flank"),
     "patch = 'flank': not a contact of the geometry"),
    (lambda d: d["assembly"]["contacts"][0].pop("mu"), "mu: missing"),
    (lambda d: d["assembly"]["contacts"][0].update(mu=-1), "mu = -1: must be >= 0"),
    (lambda d: d["assembly"]["contacts"][0].update(elements="3D"), "elements = '3D'"),
    (lambda d: d["assembly"]["loads"][0].update(direction="up"), "direction = 'up'"),
    (lambda d: d["assembly"]["loads"][0].update(node_set="blisk/hub"),
     "node_set = 'blisk/hub': not a node set"),
    (lambda d: d["assembly"].update(speed=-3), "assembly.speed = -3"),
    (lambda d: d["assembly"].update(centrifugal=["rotor"]), "'rotor' is not a body"),
    (lambda d: d["assembly"].update(colour=1), "assembly.colour: unknown key"),
    # every geometry parameter against its class before anything runs
    (lambda d: d["geometry"]["parameters"].update(blade_sise=0.01),
     "geometry.parameters.blade_sise: unknown key; did you mean 'blade_size'?"),
    (lambda d: d["geometry"]["parameters"].update(contact_n_axial=0),
     "geometry.parameters.contact_n_axial = 0: must be an integer in [2, 500]"),
    (lambda d: d["geometry"]["parameters"].update(size="fine"),
     "geometry.parameters.size = 'fine' m: must be a finite number in (0, 10] m"),
    (lambda d: d["geometry"]["parameters"].update(platform_gap=0.5),
     "geometry.parameters.platform_gap = 0.5: must be < "),
    (lambda d: d["assembly"]["loads"][0].update(harmonic=2),
     "assembly.loads[0].harmonic = 2: that order is not computed (harmonics.max = 1"),
    (lambda d: d["assembly"].update(mass_multiplier=0), "mass_multiplier = 0: must be > 0"),
    (lambda d: d["analysis"][0].update(outputs=["hub"]), "'hub' is not a DOF"),
    (lambda d: d["analysis"][0].update(parameter="preload", frequency=3000.0),
     "an assembly case sweeps"),
    (lambda d: d["analysis"][0].update(type="dti"), "an assembly case runs"),
    (lambda d: d.update(model={"dofs": ["x"]}), "remove [model]"),
    (lambda d: d["analysis"][0].update(maps=["top"]),
     "maps: 'top' is neither 'peak' nor a parameter value in the range 3200..3300"),
    (lambda d: d["analysis"][0].update(maps=[4000.0]), "maps: 4000.0 is neither"),
    (lambda d: d["analysis"][0].update(map_types=["modes"]), "map_types = ['modes']"),
    (lambda d: d["assembly"].update(excitation=0), "assembly.excitation = 0: must be > 0"),
    (lambda d: d["assembly"].update(static_anchor=2.0), "static_anchor = 2.0"),
    (lambda d: d["analysis"][0].update(normalise="yes"), "normalise = 'yes'"),
])
def test_faults_are_reported_before_any_meshing(monkeypatch, mutate, expected):
    monkeypatch.setitem(geometry.MODELS, "blisk_sector",
                        lambda *a, **k: pytest.fail("meshed before the check"))
    assert any(expected in f for f in faults(mutate)), faults(mutate)


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    """The coarse case run once (mesh, reduction, FRF with maps): its results folder."""
    out = tmp_path_factory.mktemp("coarse")
    run_case(cases.Case(copy.deepcopy(CASE), "coarse.toml"), out, progress=lambda s: None)
    return out


def test_the_multipliers_of_the_assembly_table_set_the_operating_point():
    data = copy.deepcopy(CASE)
    data["assembly"].update(excitation=3.0, mass_multiplier=5.0)
    point = cases.operating_point(cases.Case(data, "c.toml"), 3100.0)
    assert (point.omega, point.excitation, point.mass_multiplier) == (3100.0, 3.0, 5.0)


def test_an_assembly_case_runs_end_to_end(coarse_run):
    tmp_path = coarse_run
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["status"] == "complete"
        curve = f["frf/curve_000"]
        assert curve.attrs["status"] == "complete"
        n = curve["parameter"].shape[0]
        assert n > 3
        # per point: the contact unknowns, per node pair its state and static forces
        assert curve["unknowns"].shape == (n, 72 * 3)  # 2 x 6 pairs x 2 nodes x 3, 3 coeffs
        # every contact DOF named by its mesh node (the patches' nodes) and direction
        nodes = set(curve["unknown_nodes"][()].tolist())
        assert len(nodes) == 24 and sorted(np.bincount(curve["unknown_directions"][()])) == [
            24, 24, 24]
        for name, pairs, comps in (("damper_left", 6, 3), ("damper_right.t1", 6, 2)):
            g = curve["contacts"][name]
            assert g["node_state"].shape == (n, pairs)
            assert g["static_force"].shape == (n, pairs * comps)
        stuck = f["frf/linear_stuck/response"][()]
        free = f["frf/linear_free/response"][()]
        assert stuck.shape == free.shape == (201, 1)
        assert np.all(np.isfinite(curve["response"][()]))
    assert (tmp_path / "frf_tip.png").stat().st_size > 10_000


def test_a_patch_draws_its_total_static_forces_per_component():
    # 3 node pairs x [T1, T2, N]: three lines, each the sum over the pairs (not nine)
    from microslip.draw.pictures import static_lines

    static = np.arange(18.0).reshape(2, 9)  # 2 points of the curve
    patch = static_lines(static, ["T0_1", "T0_2", "N0"])
    assert [w for w, _ in patch] == ["sum T0_1", "sum T0_2", "sum N0"]
    for j, (_, y) in enumerate(patch):
        np.testing.assert_array_equal(y, static.reshape(2, 3, 3)[:, :, j].sum(axis=1))
    # one point: its components as they are
    single = static_lines(static[:, :2], ["T0", "N0"])
    assert [w for w, _ in single] == ["T0", "N0"]
    np.testing.assert_array_equal(single[1][1], static[:, 1])


def test_the_results_file_follows_the_layout(coarse_run):
    from microslip.results import schema

    with h5py.File(coarse_run / "results.h5") as f:  # geometry, reduction, maps, shapes
        assert schema.undescribed(f) == []


def test_the_patches_hold_each_pairs_state_and_the_share_of_slipping_pairs(coarse_run):
    from microslip.laws.states import GROSS_SLIP, STICK_SLIP

    with h5py.File(coarse_run / "results.h5") as f:
        curve = f["frf/curve_000"]
        n = curve["parameter"].shape[0]
        for patch, parts in (("damper_left", ["damper_left"]),
                             ("damper_right", ["damper_right.t1", "damper_right.t2"])):
            p = curve["patches"][patch]
            state = p["state"][()]
            assert state.shape == (n, 6) and p["static"].shape == (n, 6, 3)
            # a 1D+1D pair is as bad as its worse element (they share the normal)
            expected = np.max([curve["contacts"][c]["node_state"][()] for c in parts], axis=0)
            np.testing.assert_array_equal(state, expected)
            share = np.isin(state, (STICK_SLIP, GROSS_SLIP)).mean(axis=1)
            np.testing.assert_allclose(p["slip_share"][()], share, rtol=0, atol=1e-15)
            # static forces: [T1, T2, N] of the 2D element, or T of each 1D one and N summed
            static = curve["contacts"][parts[0]]["static_force"][()].reshape(n, 6, -1)
            if len(parts) == 1:
                np.testing.assert_array_equal(p["static"][()], static)
            else:
                other = curve["contacts"][parts[1]]["static_force"][()].reshape(n, 6, -1)
                np.testing.assert_array_equal(p["static"][:, :, 1], other[:, :, 0])
                np.testing.assert_allclose(p["static"][:, :, 2], static[:, :, 1] + other[:, :, 1])


def test_the_map_points_are_solutions_at_the_peak_and_at_the_asked_frequency(coarse_run):
    with h5py.File(coarse_run / "results.h5") as f:
        curve = f["frf/curve_000"]
        points = {k: p for k, p in curve["maps"].items()}
        assert sorted(points) == ["point_00", "point_01"]
        peak, at = points["point_00"], points["point_01"]
        assert peak.attrs["what"] == "peak"
        # the peak is at least the largest computed response of the branch
        assert peak["response"][0] >= curve["response"][:, 0].max() * (1 - 1e-12)
        assert at.attrs["parameter"] == 3250.0
        lam, resp = curve["parameter"][()], curve["response"][:, 0]
        # the solution at 3250 lies between its computed neighbours' responses
        j = np.searchsorted(lam, 3250.0)
        lo, hi = sorted(resp[j - 1: j + 1])
        assert lo - 1e-12 <= at["response"][0] <= hi + 1e-12


def test_the_map_colours_of_the_nodes_equal_their_stored_states(coarse_run):
    from matplotlib.colors import to_rgb

    from microslip.draw import maps

    with h5py.File(coarse_run / "results.h5") as f:
        point = f["frf/curve_000/maps/point_00/patches"]
        for name, g in f["contact_grids"].items():
            grid = maps.PatchGrid.from_group(name, g)
            state = point[name]["state"][()]
            sg = maps.cells(grid, maps.state_rgb(state), "rgb")
            for k, (x, y) in enumerate(1e3 * grid.plane.reshape(-1, 2)):
                cell = sg.find_containing_cell([x, y, 0.0])
                rgb = np.round(255 * np.array(to_rgb(maps.STATE_COLOURS[state[k]])))
                np.testing.assert_array_equal(sg.cell_data["rgb"][cell], rgb)


def checked_layouts(monkeypatch) -> dict[str, list[str]]:
    """Every VTK picture drawn from now on: its layout faults (:func:`layout_faults`) by
    its file name, taken as it is saved."""
    import pyvista as pv

    faults, original = {}, pv.Plotter.screenshot

    def screenshot(self, filename=None, *args, **kwargs):
        faults[Path(str(filename)).name.replace(".tmp", "").lstrip(".")] = \
            layout_faults(self)
        return original(self, filename, *args, **kwargs)

    monkeypatch.setattr(pv.Plotter, "screenshot", screenshot)
    return faults


def edge_ink(png: Path) -> bool:
    """Whether a picture has dark pixels (text, lines) on its outermost 2 pixels: drawn
    past its edge."""
    from PIL import Image

    grey = np.asarray(Image.open(png).convert("L"))
    return bool((np.concatenate([grey[:2].ravel(), grey[-2:].ravel(), grey[:, :2].ravel(),
                                 grey[:, -2:].ravel()]) < 128).any())


def test_render_redraws_the_pictures_from_the_results_file_alone(coarse_run, tmp_path,
                                                                   monkeypatch):
    from PIL import Image

    layouts = checked_layouts(monkeypatch)

    # no model may be rebuilt: render reads results.h5 only
    monkeypatch.setitem(geometry.MODELS, "blisk_sector",
                        lambda *a, **k: pytest.fail("render meshed"))
    assert main(["render", str(coarse_run), "--out", str(tmp_path), "--at", "3260",
                 "--size", "300x200", "--colour", "stick=lightyellow"]) == 0
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    previews = ["blisk_sector_sector.png", "blisk_sector_contacts.png",
                "blisk_sector_full_disk.png"]
    assert names == sorted(["frf_tip.png", "frf_status.png", "frf_normal_load.png",
                            "frf_static_damper_left.png", "frf_static_damper_right.t1.png",
                            "frf_static_damper_right.t2.png", *previews])
    for name in previews:  # the mesh previews as the run drew them, pixel for pixel
        np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / name)),
                                      np.asarray(Image.open(coarse_run / name)), err_msg=name)
    # one row of maps (--at: one point per curve), two patches of 300 x 200 pixels, the
    # title (broken into lines to fit 600 px) and the legend in strips of their own
    w, h = Image.open(tmp_path / "frf_status.png").size
    assert w == 600 and 200 + 60 < h < 200 + 200
    # no text off the picture, out of its strip or over another text or a map, measured
    # by VTK as each picture is saved; no ink on any picture's edge
    assert set(layouts) >= {"frf_status.png", "frf_normal_load.png", *previews}
    assert not any(layouts.values()), layouts
    assert not [p.name for p in tmp_path.glob("*.png") if edge_ink(p)]


@pytest.mark.slow
@pytest.mark.parametrize("size", ["1400x400", "300x700", "520x420"])
def test_no_map_or_shape_text_runs_off_or_over_another_at_any_size(coarse_run, tmp_path,
                                                                    monkeypatch, size):
    layouts = checked_layouts(monkeypatch)
    assert main(["render", str(coarse_run), "--out", str(tmp_path), "--size", size,
                 "--maps", "status,normal_load,shape", "--analysis", "frf"]) == 0
    assert {"frf_status.png", "frf_normal_load.png", "frf_shape_a.png"} <= set(layouts)
    assert not any(layouts.values()), layouts
    assert not [p.name for p in tmp_path.glob("*.png") if edge_ink(p)]


def test_the_shapes_at_the_map_points_are_the_solution_on_the_contact_nodes(coarse_run):
    # every contact node is a master and on its body's surface: its recovered displacement
    # there must be the harmonic-balance unknowns of that node, coefficient for coefficient
    with h5py.File(coarse_run / "results.h5") as f:
        curve = f["frf/curve_000"]
        dof_nodes, dirs = curve["unknown_nodes"][()], curve["unknown_directions"][()]
        n_coeffs = 3
        for point in curve["maps"].values():
            x = point["unknowns"][()].reshape(-1, n_coeffs)  # (n_dof, n_coeffs)
            checked = 0
            for body, g in f["surfaces"].items():
                nodes, u = g["nodes"][()], point["shapes"][body][()]
                assert u.shape == (len(nodes), 3, n_coeffs)
                for k in np.flatnonzero(np.isin(dof_nodes, nodes)):
                    i = np.searchsorted(nodes, dof_nodes[k])
                    # recovery is a product with the identity rows of the masters: rounding
                    np.testing.assert_allclose(u[i, dirs[k]], x[k], rtol=1e-9,
                                               atol=1e-12 * np.abs(x).max())
                    checked += 1
            assert checked == x.shape[0]  # every contact DOF is a surface DOF of its body


def test_the_full_disk_is_continuous_across_every_sector_boundary(coarse_run):
    from microslip.draw import shapes

    # copy s's right cyclic face is copy s+1's left face: one node of the disk, one motion.
    # Wrong phases (or a wrong sign of the wave) tear the disk apart at these faces.
    mesh = geometry.MODELS["blisk_sector"](**CASE["geometry"]["parameters"])
    cyc = mesh.cyclic["blisk"]
    with h5py.File(coarse_run / "results.h5") as f:
        surfaces, shape = shapes.read(f, f["frf/curve_000/maps/point_00"])
        nodes = f["surfaces/blisk/nodes"][()]
    assert shape.sectors == 6 and shape.wave_numbers == (0, 1)
    left, right = np.searchsorted(nodes, cyc.left), np.searchsorted(nodes, cyc.right)
    scale = max(np.abs(shape.vibration("blisk", t)).max() for t in (0.0, 1.0))
    for theta in (0.0, 1.0, 2.5):
        for s in range(6):
            a = shape.vibration("blisk", theta, s)[right]
            b = shape.vibration("blisk", theta, (s + 1) % 6)[left]
            # the cyclic constraint holds to the reduced model's rounding
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * scale)


def test_a_shape_picture_is_a_non_blank_png_of_the_asked_size(coarse_run, tmp_path,
                                                              monkeypatch):
    from PIL import Image

    layouts = checked_layouts(monkeypatch)
    assert main(["render", str(coarse_run), "--out", str(tmp_path), "--maps", "shape",
                 "--size", "400x300"]) == 0
    names = sorted(p.name for p in tmp_path.glob("frf_shape_*.png"))
    assert names == ["frf_shape_a.png", "frf_shape_b.png"]
    image = np.asarray(Image.open(tmp_path / "frf_shape_a.png").convert("RGB"))
    # two panels of 400 x 300 between the title and captions' strips and the colour scale
    assert image.shape[1:] == (800, 3) and 300 + 100 < image.shape[0] < 300 + 300
    assert (image.min(axis=2) < 200).mean() > 0.05  # a drawn model, not a white page
    assert layouts["frf_shape_a.png"] == [] and not edge_ink(tmp_path / "frf_shape_a.png")
    # the summary names the surfaces, not as an analysis of no points
    from microslip.results.writer import summary

    text = summary(coarse_run / "results.h5")
    assert "surfaces (of the previews and shapes): blisk" in text and " 0 points" not in text


@pytest.mark.parametrize("args, expected", [
    (["render", "nowhere"], "no results file at nowhere"),
    (["render", "{run}", "--colour", "wet=blue"], "'wet' is not a state"),
    (["render", "{run}", "--colour", "open=notacolour"], "is not a colour"),
    (["render", "{run}", "--size", "10x10"], "--size 10x10: expected WIDTHxHEIGHT"),
    (["render", "{run}", "--maps", "shapes"], "not among ['status', 'normal_load', 'shape']"),
])
def test_render_rejects_bad_input_with_one_line_and_exit_2(coarse_run, capsys, args,
                                                            expected):
    argv = [a.replace("{run}", str(coarse_run)) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err


def test_a_rerun_reuses_every_unchanged_curve_and_recomputes_a_changed_one(coarse_run,
                                                                            tmp_path):
    import shutil

    shutil.copytree(coarse_run, tmp_path, dirs_exist_ok=True)
    lines: list[str] = []
    run_case(cases.Case(copy.deepcopy(CASE), "coarse.toml"), tmp_path, progress=lines.append)
    assert any("curve 1: 1" in x or "from the cache" in x for x in lines)
    assert not any(" point 1, value" in x for x in lines)  # no continuation ran
    assert "[frf] pictures unchanged (8 files)" in lines  # nor any drawing (2 shapes)
    assert any("previews unchanged" in x for x in lines)
    with h5py.File(coarse_run / "results.h5") as a, h5py.File(tmp_path / "results.h5") as b:
        for key in ("parameter", "response", "unknowns"):
            np.testing.assert_array_equal(a["frf/curve_000"][key][()],
                                          b["frf/curve_000"][key][()])
        np.testing.assert_array_equal(a["frf/linear_stuck/response"][()],
                                      b["frf/linear_stuck/response"][()])
    # another damper mass: that curve (and its stuck limit) again, the free limit reused
    changed = copy.deepcopy(CASE)
    changed["assembly"]["mass_multiplier"] = 3.0
    lines.clear()
    run_case(cases.Case(changed, "coarse.toml"), tmp_path, progress=lines.append)
    assert any(" point 1, value" in x for x in lines)
    assert not any("from the cache" in x for x in lines if "curve 1" in x)
    assert not any("pictures unchanged" in x for x in lines)  # a new curve: drawn again
    with h5py.File(tmp_path / "results.h5") as f:
        assert f["frf/curve_000"].attrs["mass_multiplier"] == 3.0
        assert f["frf/linear_stuck"].attrs["mass_multiplier"] == 3.0


def test_no_cache_computes_afresh_and_keeps_nothing(tmp_path):
    from microslip.app.store import CurveStore

    store = CurveStore(None)
    key = store.key({"a": 1}, {"type": "frf"}, method="arclength")
    assert not store.has(key) and store.key({"a": 1}, {"type": "frf", "name": "x"},
                                            method="arclength") == key
    # a drawing key does not change the curve; a computing key does
    assert store.key({"a": 1}, {"type": "frf", "map_types": ["status"]},
                     method="arclength") == key
    assert store.key({"a": 2}, {"type": "frf"}, method="arclength") != key


def test_a_dry_run_lists_what_comes_from_the_caches_and_what_runs(coarse_run, monkeypatch):
    from microslip.app import plan
    from microslip.solve import response

    monkeypatch.setattr(response, "sweep", lambda *a, **k: pytest.fail("a dry run solved"))
    stages = plan.plan(cases.Case(copy.deepcopy(CASE), "coarse.toml"), coarse_run)
    by_name = {s.name: s for s in stages}
    assert by_name["reduction: blisk ND 0"].cached and by_name["reduction: damper"].cached
    assert by_name["frf: curve 1"].cached
    assert not by_name["geometry: Gmsh mesh and previews"].cached
    # another damper mass: the models are reused, the curve runs, with an estimate
    changed = copy.deepcopy(CASE)
    changed["assembly"]["mass_multiplier"] = 7.0
    stages = {s.name: s for s in plan.plan(cases.Case(changed, "c.toml"), coarse_run)}
    assert stages["reduction: blisk ND 1"].cached
    assert not stages["frf: curve 1"].cached and stages["frf: curve 1"].seconds > 0
    assert stages["frf: curve 1"].nbytes > 0
    # no cache at all: every curve runs
    fresh = {s.name: s for s in plan.plan(cases.Case(copy.deepcopy(CASE), "c.toml"),
                                          coarse_run, cache=False)}
    assert not fresh["frf: curve 1"].cached
    text = plan.text(list(fresh.values()))
    assert "stages run" in text and "cached" in text


def test_a_bodys_recovered_displacement_at_its_masters_is_the_solution_there(tmp_path):
    # Craig-Bampton keeps the masters' DOFs as they are (identity rows of the recovery):
    # the response node, a master of the blisk and one of its recovery nodes, moves as the
    # harmonic balance's shared DOFs say, order by order (the ND's complex wave included)
    from microslip.app.models import AssemblyModels
    from microslip.app.stages import mesh_geometry
    from microslip.app.structure import reduce_structure
    from microslip.solve.linear import OperatingPoint

    case = cases.Case(copy.deepcopy(CASE), "coarse.toml")
    mesh = mesh_geometry(GeometryTable.of(CASE["geometry"]), tmp_path, progress=lambda s: None,
                         pictures=False)
    result = reduce_structure(mesh, CASE["reduction"], None, cases.harmonics(case).orders,
                              progress=lambda s: None)
    cm = AssemblyModels(mesh, result).assembly(case)
    rng = np.random.default_rng(3)
    x = rng.standard_normal(cm.hb.dofs.size * cm.hb.harmonics.n_coeffs) * 1e-6
    point = OperatingPoint(3210.0, mass_multiplier=2.0)
    node = int(np.ravel(mesh.node_sets["blisk/response"])[0])
    nodes, U = cm.displacements(x, point, "blisk", np.array([node]))
    Q = cm.hb.recover(x, point)
    dof = int(np.flatnonzero(cm.dof_nodes == node)[0])
    np.testing.assert_allclose(U[0], Q[dof: dof + 3], rtol=1e-12, atol=1e-18)
    # and the modal part is there: the tip (not a master) moves, and by the reduced
    # coordinates through the recovery matrix of each order's ND
    tip_nodes, tip = cm.displacements(x, point, "blisk")
    q = cm.body_coordinates(x, point)["blisk"]
    b = next(b for b in cm.layout if b.body == "blisk")
    for k, o in enumerate(cm.hb.harmonics.orders):
        R = b.models[k].recovery.conj() if b.conjugate[k] else b.models[k].recovery
        complex_tip = cm.hb.harmonics.to_complex(tip.reshape(-1, tip.shape[-1]))[o]
        np.testing.assert_allclose(complex_tip.reshape(-1, 3), R @ q[k], rtol=1e-10,
                                   atol=1e-18)
    assert np.abs(tip).max() > 0


def _copied_package(folders, to):
    """The package's folders copied under ``to`` ({package: copy})."""
    import shutil

    copies = {name: to / name for name in folders}
    for name, folder in folders.items():
        shutil.copytree(folder, copies[name], ignore=shutil.ignore_patterns("__pycache__"))
    return copies


def test_the_code_digest_follows_the_computing_sources_only(tmp_path):
    from microslip.app import store

    folders = _copied_package(store.package_folders(), tmp_path)
    package = folders["microslip"]
    before = store.code_digest(folders)
    drawn = store.code_digest(folders, store.DRAWING, ())
    assert before == store.code_digest()  # the copy is complete
    with open(package / "draw/shapes.py", "a") as f:
        f.write("# a comment\n")
    assert store.code_digest(folders) == before  # drawing: the curves stay
    assert store.code_digest(folders, store.DRAWING, ()) != drawn  # ... the pictures not
    (package / "draw/new_picture.py").write_text("# a module nobody listed\n")
    assert store.code_digest(folders, store.DRAWING, ()) != drawn
    (package / "app/new_runner.py").write_text("# a module nobody listed\n")
    assert store.code_digest(folders) != before  # a new computing module counts
    (package / "app/new_runner.py").unlink()
    with open(package / "solve/hbm.py", "a") as f:
        f.write("# a comment\n")
    assert store.code_digest(folders) != before  # numerics: every curve is computed again
    with open(folders["microslip.geometry"] / "blisk.py", "a") as f:
        f.write("# a comment\n")
    geometry = store.code_digest(folders, ("microslip.geometry",), ())
    assert geometry != store.code_digest(parts=("microslip.geometry",), leave_out=())


def test_the_code_digest_is_the_same_from_an_installed_wheel(tmp_path):
    """`pip install .` nests geometry/ inside the package folder (pyproject's package-dir):
    the same sources give the same digest there, and a folder without sources is an error,
    not the digest of nothing (which had every installed version share one digest)."""
    import shutil

    from microslip.app import store

    source = store.package_folders()
    wheel = tmp_path / "site-packages" / "microslip"
    shutil.copytree(source["microslip"], wheel, ignore=shutil.ignore_patterns("__pycache__"))
    if source["microslip.geometry"].parent != source["microslip"]:  # a checkout: nest it
        shutil.copytree(source["microslip.geometry"], wheel / "geometry",
                        ignore=shutil.ignore_patterns("__pycache__"))
    nested = {"microslip": wheel, "microslip.geometry": wheel / "geometry"}
    for parts, leave_out in ((store.COMPUTING, store.NOT_COMPUTING), (store.DRAWING, ()),
                             (("microslip.geometry", "microslip.case.geometry_table"), ())):
        assert store.code_digest(nested, parts, leave_out) == store.code_digest(
            parts=parts, leave_out=leave_out)
    with pytest.raises(RuntimeError, match="no Python sources"):
        store.code_digest({"microslip": tmp_path / "empty"})


@pytest.mark.slow  # a backbone on the assembly with maps (5 s); the type runs in test_render
def test_a_nonlinear_mode_of_the_assembly_with_its_maps_and_peaks(tmp_path):
    """A nonlinear mode of the coarse blisk + damper (its first bending at ND 1, from the
    stuck linear mode): its maps at two levels (every pair stuck, then the 1D+1D flank
    slipping), and the peak synthesized at the case's load against the forced balance
    solved directly at that frequency (lightly damped: within 1e-3, measured 1.4e-6)."""
    data = copy.deepcopy(CASE)
    data["analysis"] = [{"name": "mode", "type": "nonlinear_modes", "output": "tip",
                         "amplitude": [1e-6, 2e-3], "excitations": [1.0],
                         "maps": [1e-5, 1e-3]}]
    said = []
    path = run_case(cases.Case(data, "mode.toml"), tmp_path, progress=said.append)
    assert not [m for m in said if m.startswith("warning")], said
    with h5py.File(path) as f:
        c = f["mode/curve_000"]
        assert c.attrs["status"] == "complete"
        shares = [c["maps"][p]["patches"]["damper_right"]["slip_share"][()]
                  for p in ("point_00", "point_01")]
        assert shares[0] == 0.0 and shares[1] > 0.0
        assert c["damping_ratio"][-1] > c["damping_ratio"][0]  # the slip damps
        assert c["peak_response"][0, 0] == pytest.approx(c["peak_check"][0, 0], rel=1e-3)
    assert (tmp_path / "mode_status.png").is_file()


def test_the_page_of_a_meshed_run_shows_its_models_and_maps(coarse_run):
    """The results page of a meshed case: the reduced models as results.h5 has them (each
    body's master DOFs and modes per nodal diameter, the patches' stiffness), the mesh
    previews and the contact maps inlined, the map letters leading to the status maps."""
    import html
    import re

    from microslip.report import write_report

    raw = write_report(coarse_run).read_text()
    text = html.unescape(re.sub(r"<[^>]+>", " | ", raw))
    with h5py.File(coarse_run / "results.h5") as f:
        red = f["reduction"]
        for body in ("blisk", "damper"):
            for nd, m in red[body].items():
                row = (f"| {body} |  | {nd.removeprefix('nd')} |  | "
                       f"{int(m.attrs['n_master_dofs'])} |  | {int(m.attrs['n_modes'])} |")
                assert row in text, row
        for patch in red["contact_stiffness"]:
            assert f"| {patch} |" in text
    for picture in ("blisk_sector_contacts.png", "frf_status.png", "frf_normal_load.png"):
        assert f"<b>{picture}</b>" in raw
    assert '"target":"fig-frf_status"' in raw and "id='fig-frf_status'" in raw
