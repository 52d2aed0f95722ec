"""cases/13_imported_blade.toml: a deck from another tool (its generator reproduces the shipped
file), contacts declared between its node sets and the ground, through the whole chain to
the maps (coarsened here: linear elements, one excitation level); its faults, one line each."""

import copy
from pathlib import Path

import h5py
import numpy as np
import pytest
from blade_file import deck

from microslip import case as cases
from microslip.app.run import run_case
from microslip.cli import main
from microslip.laws.states import OPEN, STICK

CASE = Path(__file__).resolve().parents[1] / "cases" / "13_imported_blade.toml"


def test_the_shipped_deck_is_what_its_generator_writes():
    assert (CASE.parent / "imported_blade.inp").read_text() == deck()


@pytest.fixture(scope="module")
def coarse_run(tmp_path_factory):
    data = copy.deepcopy(cases.load(CASE).data)
    data["reduction"]["order"] = 1
    data["harmonics"]["samples"] = 32
    data.pop("solver")  # the default steps: the comparison below needs no resolved peak
    frf = data["analysis"][0]
    frf.update(start=2500.0, stop=2650.0)  # linear hexahedra: the mode 26 % stiffer
    frf["family"]["values"] = [0.01]  # (the slipping levels take ~0.3 s a point)
    out = tmp_path_factory.mktemp("blade")
    run_case(cases.Case(data, str(CASE)), out, progress=lambda s: None)
    return out


def test_the_imported_blade_runs_through_the_maps(coarse_run):
    with h5py.File(coarse_run / "results.h5") as f:
        assert f.attrs["status"] == "complete"
        grid = f["contact_grids/flank_left"]
        assert grid["points"].shape == (35, 3) and grid["connectivity"].shape == (24, 4)
        assert grid.attrs["body_b"] == "ground" and grid["points_b"].shape == (0, 3)
        # the flank: 45 degrees, 14 mm high, 30 mm long (the deck is in millimetres)
        p = grid["points"][()]
        assert np.ptp(p[:, 0]) == pytest.approx(0.014) and np.ptp(p[:, 2]) == pytest.approx(
            0.030)
        frf = f["frf"]
        curve = frf["curve_000"]
        # a light excitation: the root sticks where it touches (its lowest row opens under
        # the centrifugal load), and the curve follows the fully stuck system
        state = curve["maps/point_00/patches/flank_left/state"][()]
        assert set(state.tolist()) <= {STICK, OPEN} and STICK in state
        stuck = frf["linear_stuck"]
        w, response = curve["parameter"][()], curve["response"][()][:, 0]
        reference = np.interp(w, stuck["omega"][()], stuck["response"][()][:, 0])
        # the stuck curve interpolated between its own points (0.1 rad/s apart at the peak)
        np.testing.assert_allclose(response, reference, rtol=1e-2)
    for name in ("frf_status.png", "frf_normal_load.png", "import_contacts.png"):
        assert (coarse_run / name).stat().st_size > 0


@pytest.mark.parametrize("table, expected", [
    ('[geometry.contacts.flank_left]\nsurfaces = ["NOPE"]\nground = true\n',
     "geometry.contacts.flank_left.surfaces: 'NOPE' is not a node set of the mesh"),
    ('[geometry.contacts.flank_left]\nsurfaces = ["FLANK_L", "FLANK_R"]\nground = true\n',
     "geometry.contacts.flank_left.surfaces = ['FLANK_L', 'FLANK_R']: expected 1 node-set"),
    ('[geometry.contacts.flank_left]\nsurfaces = ["FLANK_L", "TIP"]\n',
     "geometry.contacts.flank_left.surfaces: both on body 'BLADE'"),
])
def test_a_bad_contact_is_one_line_before_any_work(tmp_path, capsys, table, expected):
    text = CASE.read_text()
    start = text.index("[geometry.contacts.flank_left]")
    end = text.index("[geometry.contacts.flank_right]")
    case = tmp_path / "blade.toml"
    case.write_text(text[:start] + table + "\n" + text[end:])
    (tmp_path / "imported_blade.inp").write_text(deck())
    assert main(["check", str(case)]) == 2
    err = capsys.readouterr().err
    assert expected in err and err.count("\n") <= 2, err
