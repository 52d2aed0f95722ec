"""The structural stage of a case ([reduction]): validation before any work, the NDs a case
needs, reduced models against the unreduced sector, the damper's modes from the disk's
frequency range, and reuse of unchanged models."""

import copy
import json

import h5py
import numpy as np
import pytest
import scipy.linalg as sla

import geometry
from pipeline import case as cs
from pipeline import cyclic, fem, linalg, reduction, structure
from pipeline.contact_stiffness import flat_punch_stiffness
from pipeline.run import run_case

# The default blisk sector meshed twice as coarse: the stage end to end in a few seconds.
CASE = {
    "title": "coarse blisk reduction",
    "geometry": {"model": "blisk_sector",
                 "parameters": {"sectors": 24, "size": 0.016, "blade_size": 0.008}},
    "reduction": {"nodal_diameters": [0, 5], "modes": "auto",
                  "contact_stiffness": {"damper_left": {"normal": 2.0e13,
                                                        "tangential": 1.0e13}}},
}


def faults(mutate) -> list[str]:
    data = copy.deepcopy(CASE)
    mutate(data)
    with pytest.raises(cs.CaseError) as err:
        cs.check(data)
    return err.value.faults


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
    (lambda d: d.pop("geometry"), "needs a [geometry] table"),
])
def test_bad_reduction_tables_are_named(mutate, expected):
    assert any(expected in f for f in faults(mutate)), faults(mutate)


def test_nodal_diameters_of_an_engine_order():
    # Harmonic n on ND n EO mod Ns, folded onto 0..Ns/2 (by hand: EO 20, Ns 48: 0, 20,
    # 40 -> 8, 60 -> 12).
    assert structure.needed_nodal_diameters({"engine_order": 20, "harmonics": 3}, 48) == (
        0, 8, 12, 20)
    assert structure.needed_nodal_diameters({"engine_order": 3}, 48, 3) == (0, 3, 6, 9)
    assert structure.needed_nodal_diameters({"nodal_diameters": [2, 0, 2]}, 48) == (0, 2)
    with pytest.raises(ValueError, match="nodal_diameter"):
        structure.needed_nodal_diameters({"nodal_diameters": [13]}, 24)


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
    case = cs.Case(copy.deepcopy(CASE), "coarse.toml")
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
        files = {h: out / g["blisk"][f"nd{h}"].attrs["file"] for h in (0, 5)}
        kn_left = g["contact_stiffness"]["damper_left"]["normal_n_per_m"][()]
        kn_right = g["contact_stiffness"]["damper_right"]["normal_n_per_m"][()]
    # Against the unreduced sector (independent: direct eigen-solve of K_h, M_h); the CB
    # default keeps the first ten within 0.1 % (measured here ~1e-4).
    mesh = geometry.blisk_sector(**CASE["geometry"]["parameters"])
    body = fem.assemble(mesh, "blisk", structure.STEEL)
    for h in (0, 5):
        sector = cyclic.sector_model(body, fem.node_set(mesh, "blisk/bore"),
                                     mesh.cyclic["blisk"], h)
        lam, _ = linalg.lowest_modes(sector.stiffness, sector.mass, 10)
        f_full = np.sqrt(lam) / (2 * np.pi)
        np.testing.assert_allclose(f_red[h], f_full, rtol=1e-3)
        assert files[h].exists()
        # The stored model is the one summarised.
        stored = reduction.ReducedModel.load(files[h])
        np.testing.assert_allclose(stored.frequencies(10), f_red[h], rtol=1e-12)
    # The free damper takes the disk's frequency range: f_max = the highest 10th
    # fixed-interface frequency of the blisk NDs, and keeps only its modes below 4 f_max.
    assert f_max > f_red[0][-1]
    assert damper_modes <= 5
    # Per-area stiffness from the case on the left patch, flat punch on the right.
    area = mesh.contacts["damper_left"].area
    assert np.isclose(kn_left.sum(), 2.0e13 * area, rtol=1e-12)
    kn_punch, _ = flat_punch_stiffness(mesh.contacts["damper_right"].area, structure.STEEL,
                                       structure.STEEL)
    assert np.isclose(kn_right.sum(), kn_punch, rtol=1e-12)
    assert np.allclose(kn_right, kn_right.flat[0])  # spread evenly


def test_rerun_reuses_unchanged_models(stage, monkeypatch):
    """A re-run, even with another damping (applied to the reduced matrices, not part of the
    reduction), reads every model back instead of assembling anything."""
    case, out, _ = stage
    monkeypatch.setattr(fem, "assemble", lambda *a, **k: pytest.fail("re-assembled"))
    data = copy.deepcopy(case.data)
    data["reduction"]["damping"] = {"modal_ratios": 0.002}
    path = run_case(cs.Case(data, "coarse.toml"), out, progress=lambda s: None)
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "complete"
        assert len(json.loads(f["reduction"].attrs["cached"])) == 3  # blisk ND 0, 5; damper
    mesh = geometry.blisk_sector(**CASE["geometry"]["parameters"])
    result = structure.reduce_structure(mesh, data["reduction"], out / "models",
                                        progress=lambda s: None)
    model = result.models["blisk"][5]
    assert model.damping_spec == fem.Damping(modal_ratios=(0.002,))
    # Modal damping of the reduced model: Phi^H C Phi = diag(2 zeta omega) (the modes of the
    # reduced model itself, computed here independently).
    lam, Phi = sla.eigh(model.stiffness, model.mass)
    C = Phi.conj().T @ model.damping @ Phi
    np.testing.assert_allclose(np.diag(C).real[:10], 2 * 0.002 * np.sqrt(lam[:10]), rtol=1e-6)
