"""A coupled case end to end: the [coupling] table checked before any meshing (one line per
fault), then mesh -> reduction -> coupling -> FRF with the linear limits, into results.h5."""

import copy

import h5py
import numpy as np
import pytest
from case_helpers import case_faults

from microslip import geometry
from microslip.pipeline.app import case as cs
from microslip.pipeline.app.run import run_case
from microslip.pipeline.cli import main

CASE = {
    "title": "coarse coupled blisk",
    "geometry": {"model": "blisk_sector", "parameters": {
        "sectors": 6, "size": 0.03, "blade_size": 0.012, "contact_n_axial": 3,
        "contact_n_flank": 2}},
    "reduction": {"engine_order": 1, "order": 1, "modes": "auto", "f_max": 1500.0,
                  "damping": {"modal_ratios": 0.005}},
    "harmonics": {"max": 1, "samples": 64},
    "coupling": {
        "speed": 1000.0, "centrifugal": ["damper"], "mass_multiplier": 2.0,
        "contacts": [{"patch": "damper_left", "mu": 0.5},
                     {"patch": "damper_right", "mu": 0.5, "elements": "1D+1D"}],
        "loads": [{"node_set": "blisk/excitation", "direction": "tangential",
                   "amplitude": 1.0}],
        "outputs": [{"name": "tip", "node_set": "blisk/response", "direction": "tangential"}],
    },
    "analysis": [{"name": "frf", "type": "frf", "start": 3200.0, "stop": 3300.0,
                  "outputs": ["tip"]}],
}


def faults(mutate) -> list[str]:
    return case_faults(CASE, mutate)


def test_the_shipped_case_is_valid():
    cs.check(copy.deepcopy(CASE))
    assert main(["check", "cases/blisk_damper.toml"]) == 0


@pytest.mark.parametrize("mutate, expected", [
    (lambda d: d["coupling"]["contacts"][0].update(patch="flank"),
     "patch = 'flank': not a patch of the geometry"),
    (lambda d: d["coupling"]["contacts"][0].pop("mu"), "mu: missing"),
    (lambda d: d["coupling"]["contacts"][0].update(mu=-1), "mu = -1: must be >= 0"),
    (lambda d: d["coupling"]["contacts"][0].update(elements="3D"), "elements = '3D'"),
    (lambda d: d["coupling"]["loads"][0].update(direction="up"), "direction = 'up'"),
    (lambda d: d["coupling"]["loads"][0].update(node_set="blisk/hub"),
     "node_set = 'blisk/hub': not a node set"),
    (lambda d: d["coupling"].update(speed=-3), "coupling.speed = -3"),
    (lambda d: d["coupling"].update(centrifugal=["rotor"]), "'rotor' is not a body"),
    (lambda d: d["coupling"].update(colour=1), "coupling.colour: unknown key"),
    (lambda d: d["coupling"].update(mass_multiplier=0), "mass_multiplier = 0: must be > 0"),
    (lambda d: d["analysis"][0].update(outputs=["hub"]), "'hub' is not a DOF"),
    (lambda d: d["analysis"][0].update(parameter="preload", frequency=3000.0),
     "a coupled case sweeps"),
    (lambda d: d["analysis"][0].update(type="dti"), "a coupled case runs"),
    (lambda d: d.update(model={"dofs": ["x"]}), "remove [model]"),
])
def test_faults_are_reported_before_any_meshing(monkeypatch, mutate, expected):
    monkeypatch.setitem(geometry.MODELS, "blisk_sector",
                        lambda *a, **k: pytest.fail("meshed before the check"))
    assert any(expected in f for f in faults(mutate)), faults(mutate)


def test_a_coupled_case_runs_end_to_end(tmp_path):
    path = run_case(cs.Case(copy.deepcopy(CASE), "coarse.toml"), tmp_path,
                    progress=lambda s: None)
    with h5py.File(path) as f:
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
    from microslip.pipeline.app.pictures import static_lines

    static = np.arange(18.0).reshape(2, 9)  # 2 points of the curve
    patch = static_lines(static, ["T0_1", "T0_2", "N0"])
    assert [w for w, _ in patch] == ["sum T0_1", "sum T0_2", "sum N0"]
    for j, (_, y) in enumerate(patch):
        np.testing.assert_array_equal(y, static.reshape(2, 3, 3)[:, :, j].sum(axis=1))
    # one point: its components as they are
    single = static_lines(static[:, :2], ["T0", "N0"])
    assert [w for w, _ in single] == ["T0", "N0"]
    np.testing.assert_array_equal(single[1][1], static[:, 1])
