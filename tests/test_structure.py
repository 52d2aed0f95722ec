"""The structural stage of a case ([reduction]): validation before any work, the NDs a case
needs, reduced models against the unreduced sector, the damper's modes from the disk's
frequency range, and reuse of unchanged models."""

import copy
import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.linalg as sla
from case_helpers import case_faults
from threadpoolctl import threadpool_limits

from microslip import case as cases
from microslip import geometry
from microslip.app import structure
from microslip.app.run import run_case
from microslip.case import reduction_table as reduction_table
from microslip.fe import craig_bampton, cyclic, eigen, fem, linalg, reduced_model

# The default blisk sector meshed twice as coarse: the stage end to end in a few seconds.

def _shared() -> Path:
    """The shared cache of meshes and reduced models (conftest's, for the session)."""
    return Path(os.environ["MICROSLIP_CACHE"])


CASE = {
    "title": "coarse blisk reduction",
    "geometry": {"model": "blisk_sector",
                 "parameters": {"sectors": 24, "size": 0.016, "blade_size": 0.008}},
    "reduction": {"nodal_diameters": [0, 5], "modes": "auto",
                  "contact_stiffness": {"damper_left": {"normal": 2.0e13,
                                                        "tangential": 1.0e13}}},
}


def faults(mutate) -> list[str]:
    return case_faults(CASE, mutate)


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d["reduction"].update(engine_order=3), "either nodal_diameters"),
    (lambda d: d["reduction"].update(nodal_diameters=[0, -1]), "nodal_diameters = [0, -1]"),
    (lambda d: d["reduction"].update(order=3), "reduction.order = 3: expected 1 or 2"),
    (lambda d: d["reduction"].update(modes="many"), "reduction.modes = 'many'"),
    (lambda d: d["reduction"].update(cutoff=0.5), "reduction.cutoff = 0.5"),
    (lambda d: d["reduction"].update(f_max=-1.0), "reduction.f_max = -1.0"),
    (lambda d: d["reduction"].update(backend="mumps"), "reduction.backend = 'mumps'"),
    (lambda d: d["reduction"].update(material={"youngs_modulus": 2e11, "poisson_ratio": 0.5,
                                               "density": 7850.0}), "poisson_ratio=0.5"),
    (lambda d: d["reduction"].update(bodies={"blisk": {"clamp": ["blisk/bore"]}}),
     "reduction.bodies.blisk.clamp: unknown key"),
    (lambda d: d["reduction"]["contact_stiffness"]["damper_left"].update(normal=0.0),
     "damper_left.normal = 0.0"),
    (lambda d: d["reduction"].update(sweep=1), "reduction.sweep: unknown key"),
    (lambda d: d["reduction"].update(damping={"modal_ratios": [0.01, -0.1]}),
     "reduction.damping: modal_ratios"),
    (lambda d: d["reduction"].update(damping={"zeta": 0.01}), "reduction.damping: expected"),
    (lambda d: d["reduction"].update(damping={"modal_ratios": True}), "expected numbers"),
    (lambda d: d["reduction"].update(material={"youngs_modulus": "2e11", "poisson_ratio": 0.3,
                                               "density": 7850.0}),
     "youngs_modulus = '2e11': expected numbers"),
    (lambda d: d["reduction"].update(nodal_diameters=[0, 13]), "at most sectors / 2 = 12"),
    (lambda d: d["reduction"].update(harmonics=3), "reduction.harmonics: only with"),
    (lambda d: d.update(harmonics=3), "harmonics: expected a table"),
    (lambda d: d.update(harmonics={"max": -2}), "harmonics.max = -2"),
    (lambda d: d.update(geometry={"model": "beam"}), "reduction.nodal_diameters: the geometry"),
    (lambda d: d.pop("geometry"), "needs a [geometry] table"),
])
def test_bad_reduction_tables_are_named(mutate, expected):
    assert any(expected in f for f in faults(mutate)), faults(mutate)


def test_backend_not_installed_is_named(monkeypatch):
    monkeypatch.setattr(linalg, "available_backends", lambda: ("superlu",))
    found = faults(lambda d: d["reduction"].update(backend="pardiso"))
    assert any("reduction.backend = 'pardiso': not installed" in f for f in found)


def test_nodal_diameters_of_an_engine_order():
    # Harmonic n on ND n EO mod Ns, folded onto 0..Ns/2 (by hand: EO 20, Ns 48: 0, 20,
    # 40 -> 8, 60 -> 12).
    assert reduction_table.needed_nodal_diameters({"engine_order": 20, "harmonics": 3}, 48) == (
        0, 8, 12, 20)
    assert reduction_table.needed_nodal_diameters({"engine_order": 3}, 48, range(4)) == (0, 3, 6, 9)
    # The case's odd orders 1, 3, 5 under EO 3: 3, 9, 15, and 0 for the static part.
    assert reduction_table.needed_nodal_diameters({"engine_order": 3}, 48, [1, 3, 5]) == (
        0, 3, 9, 15)
    assert reduction_table.needed_nodal_diameters({"engine_order": 3}, 48) == (0, 3)  # orders 0, 1
    assert reduction_table.needed_nodal_diameters({"nodal_diameters": [2, 0, 2]}, 48) == (0, 2)
    with pytest.raises(ValueError, match="nodal_diameter"):
        reduction_table.needed_nodal_diameters({"nodal_diameters": [13]}, 24)


def test_unknown_sets_bodies_and_patches_fail_before_assembly(monkeypatch):
    mesh = geometry.blisk_sector(**CASE["geometry"]["parameters"])
    monkeypatch.setattr(fem, "assemble", lambda *a, **k: pytest.fail("assembled"))
    for red, message in (
        ({"bodies": {"blisk": {"masters": ["blisk/nope"]}}}, "blisk/nope"),
        ({"bodies": {"rotor": {}}}, "rotor"),
        ({"contact_stiffness": {"tip": {"normal": 1.0, "tangential": 1.0}}}, "tip"),
    ):
        with pytest.raises(ValueError, match=message):
            structure.reduce_structure(mesh, {"nodal_diameters": [0]} | red, None,
                                       progress=lambda s: None)


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    out = tmp_path_factory.mktemp("reduction")
    case = cases.Case(copy.deepcopy(CASE), "coarse.toml")
    path = run_case(case, out, progress=lambda s: None)
    return case, out, path


def test_stage_reduces_every_body_at_every_nd(stage):
    case, out, path = stage
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "complete"
        g = f["reduction"]
        assert [int(h) for h in g.attrs["nodal_diameters"]] == [0, 5]
        assert set(g["blisk"]) == set(g["damper"]) == {"nd0", "nd5"}
        f_red = {h: g["blisk"][f"nd{h}"]["frequencies_hz"][()] for h in (0, 5)}
        damper_modes = int(g["damper"]["nd0"].attrs["n_modes"])
        f_max = float(g.attrs["f_max_hz"])
        fixed_interface = {h: g["blisk"][f"nd{h}"]["mode_frequencies_hz"][()] for h in (0, 5)}
        damper_fixed_interface = g["damper"]["nd0"]["mode_frequencies_hz"][()]
        damper_masters = g["damper"]["nd0"]["master_nodes"][()]
        # (the models are in the shared cache, by file name: conftest's for the tests)
        files = {h: _shared() / "models" / g["blisk"][f"nd{h}"].attrs["file"] for h in (0, 5)}
        kn_left = g["contact_stiffness"]["damper_left"]["normal_n_per_m"][()]
        kn_right = g["contact_stiffness"]["damper_right"]["normal_n_per_m"][()]
    # Against the unreduced sector (independent: direct eigen-solve of K_h, M_h); the CB
    # default keeps the first ten within 0.1 % (measured here ~1e-4).
    mesh = geometry.blisk_sector(**CASE["geometry"]["parameters"])
    body = fem.assemble(mesh, "blisk", reduction_table.STEEL)
    for h in (0, 5):
        sector = cyclic.sector_model(body, fem.node_set(mesh, "blisk/bore"),
                                     mesh.cyclic["blisk"], h)
        lam, _ = eigen.lowest_modes(sector.stiffness, sector.mass, 10)
        f_full = np.sqrt(lam) / (2 * np.pi)
        np.testing.assert_allclose(f_red[h], f_full, rtol=1e-3)
        assert np.all(f_red[h] >= f_full * (1 - 1e-9))  # a Ritz projection: from above
        assert files[h].exists()
        # The stored model is the one summarised.
        stored = reduced_model.ReducedModel.load(files[h])
        with threadpool_limits(limits=1, user_api="blas"):  # (as the run's: --threads 1)
            np.testing.assert_allclose(stored.frequencies(10), f_red[h], rtol=1e-12)
    # The free damper takes the disk's frequency range: f_max = the highest 10th
    # fixed-interface frequency of the blisk NDs, and keeps exactly its modes below 4 f_max
    # (at least one), which a direct eigen-solve of the held damper confirms.
    assert f_max == max(fixed_interface[h][9] for h in (0, 5))
    damper_full = _fixed_interface_frequencies(mesh, "damper", damper_masters, 10)
    assert damper_modes == max(1, np.sum(damper_full < reduced_model.CUTOFF * f_max)) < 10
    # (eigen tolerance 1e-6 on the residual: eigenvalues to ~1e-12)
    np.testing.assert_allclose(damper_fixed_interface, damper_full[:damper_modes], rtol=1e-8)
    # Per-area stiffness from the case on the left patch; flat punch on the right, by hand:
    # kn = 2 a E*, a = sqrt(A / pi), E* = E / (2 (1 - nu^2)) for two steel bodies.
    area = mesh.contacts["damper_left"].area
    assert np.isclose(kn_left.sum(), 2.0e13 * area, rtol=1e-12)
    a = np.sqrt(mesh.contacts["damper_right"].area / np.pi)
    assert np.isclose(kn_right.sum(), 2 * a * 2.0e11 / (2 * (1 - 0.3**2)), rtol=1e-12)
    assert np.allclose(kn_right, kn_right.flat[0])  # spread evenly


def _fixed_interface_frequencies(mesh, body, masters, k):
    """The lowest k frequencies [Hz] of a non-cyclic body with its master vertices held (the
    P2 edge DOFs between them stay free, as in Craig-Bampton), by a direct eigen-solve."""
    model = fem.assemble(mesh, body, reduction_table.STEEL)
    held = model.dofs_of_nodes(masters, "masters").ravel()
    free = np.setdiff1d(np.arange(model.stiffness.shape[0]), held)
    K, M = model.stiffness[free][:, free], model.mass[free][:, free]
    lam, _ = eigen.lowest_modes(K, M, k)
    return np.sqrt(lam) / (2 * np.pi)


def test_rerun_reuses_unchanged_models(stage, monkeypatch):
    """A re-run, even with another damping (applied to the reduced matrices, not part of the
    reduction), reads every model back instead of assembling anything."""
    case, out, _ = stage
    monkeypatch.setattr(fem, "assemble", lambda *a, **k: pytest.fail("re-assembled"))
    data = copy.deepcopy(case.data)
    data["reduction"]["damping"] = {"modal_ratios": 0.002}
    path = run_case(cases.Case(data, "coarse.toml"), out, progress=lambda s: None)
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "complete"
        assert len(json.loads(f["reduction"].attrs["cached"])) == 3  # blisk ND 0, 5; damper
    mesh = geometry.blisk_sector(**CASE["geometry"]["parameters"])
    result = structure.reduce_structure(mesh, data["reduction"], _shared() / "models",
                                        progress=lambda s: None)
    model = result.models["blisk"][5]
    assert model.damping_spec == fem.Damping(modal_ratios=(0.002,))
    # Modal damping of the reduced model: Phi^H C Phi = diag(2 zeta omega) (the modes of the
    # reduced model itself, computed here independently).
    lam, Phi = sla.eigh(model.stiffness, model.mass)
    C = Phi.conj().T @ model.damping @ Phi
    np.testing.assert_allclose(np.diag(C).real[:10], 2 * 0.002 * np.sqrt(lam[:10]), rtol=1e-6)


def test_a_copied_case_in_another_folder_meshes_and_reduces_nothing(stage, tmp_path,
                                                                    monkeypatch):
    """The models and the mesh are kept for every run of the user, not per output folder: a
    copy of the case with another title and damping, run elsewhere, meshes and assembles
    nothing, and says where they came from."""
    case, _, _ = stage
    monkeypatch.setattr(fem, "assemble", lambda *a, **k: pytest.fail("re-assembled"))
    monkeypatch.setitem(geometry.MODELS, "blisk_sector", lambda **k: pytest.fail("re-meshed"))
    data = copy.deepcopy(case.data) | {"title": "a copy"}
    data["reduction"]["damping"] = {"modal_ratios": 0.01}
    lines: list[str] = []
    run_case(cases.Case(data, "copy.toml"), tmp_path / "elsewhere", progress=lines.append)
    where = _shared()
    assert any(x.startswith("[geometry] blisk_sector: ") and
               f"from the shared cache ({where / 'meshes'})" in x for x in lines), lines
    assert f"[reduction] 3 of 3 models from the shared cache ({where / 'models'})" in \
        "\n".join(lines)


def test_show_summarises_the_stage(stage):
    from microslip.results.writer import summary

    _, _, path = stage
    text = summary(path)
    assert "nodal diameters [0, 5]" in text
    lines = [line for line in text.splitlines() if line.startswith("  blisk nd")]
    assert [line.split()[1] for line in lines] == ["nd0:", "nd5:"]
    assert all("master DOFs +" in line and "f [Hz]" in line for line in lines)
    assert any(line.startswith("  contact damper_left: kn") for line in text.splitlines())


def test_a_failed_eigen_solve_names_body_and_nd(tmp_path, monkeypatch, capsys):
    """An eigen-solve that cannot converge (a tolerance no solver meets) ends the run failed,
    exit 1, with one message naming the body, the ND, what was tried and what to change,
    kept in results.h5; no traceback."""
    from microslip import cli

    path = tmp_path / "coarse.toml"
    path.write_text(
        '[geometry]\nmodel = "blisk_sector"\n'
        "[geometry.parameters]\nsectors = 24\nsize = 0.03\nblade_size = 0.015\n"
        "[reduction]\nnodal_diameters = [5]\nmodes = 6\n")
    monkeypatch.setattr(craig_bampton, "EIGEN_TOL", 1e-18)  # below any round-off floor
    monkeypatch.setattr(eigen, "MAX_RESTARTS", 3)  # it fails the same way, sooner
    code = cli.main(["run", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 1
    assert "reduction of body 'blisk' at ND 5" in err and "block shift-invert Lanczos" in err
    assert "to change: set [reduction.bodies.blisk] modes to fewer" in err
    assert "Traceback" not in err
    with h5py.File(tmp_path / "out" / "results.h5", "r") as f:
        assert f.attrs["status"] == "failed"
        assert "reduction of body 'blisk' at ND 5" in f.attrs["message"]


@pytest.mark.parametrize("bodies, expected", [
    ("", "body 'disk' has no master nodes"),
    ('[reduction.bodies.disk]\nmasters = ["disk/rim"]\n',
     "are on the cyclic face that follows the other"),
    ('[reduction.bodies.disk]\nmasters = ["disk/bore"]\n', "are clamped"),
])
def test_masters_a_model_names_only_once_meshed_are_one_line(tmp_path, capsys, bodies,
                                                            expected):
    """What a parametric model's names resolve to is known once it is meshed: a body without
    masters, or masters without DOFs of their own, end the run there, one line, exit 2."""
    from microslip import cli

    path = tmp_path / "disk.toml"
    path.write_text('[geometry]\nmodel = "annular_sector"\n[reduction]\nnodal_diameters = '
                    f"[1]\n{bodies}")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count("\n") == 1 and "Traceback" not in err
