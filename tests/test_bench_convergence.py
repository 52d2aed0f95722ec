"""`microslip bench convergence`: Richardson's extrapolation against a closed form, the mesh
levels as valid cases with every size scaled and the grid held, bad input in one line."""

import math

import numpy as np
import pytest

from microslip import case as cases
from microslip.bench import convergence
from microslip.cli import main


@pytest.mark.parametrize("p", [1.0, 2.0, 3.7])
def test_richardson_recovers_the_order_and_the_limit_of_a_power_law(p):
    h = 0.008 * np.array([2.0, math.sqrt(2.0), 1.0, math.sqrt(0.5)])
    w = 3100.0 + 5e4 * h**p
    order, limit = convergence.richardson(h, w)
    # exact for w = w_inf + C h^p: round-off of the logarithms only
    assert order == pytest.approx(p, rel=1e-9)
    assert limit == pytest.approx(3100.0, rel=1e-12)


def test_richardson_refuses_changes_that_do_not_shrink():
    h = np.array([0.004, 0.002, 0.001])
    order, limit = convergence.richardson(h, np.array([3.0, 2.0, 0.5]))  # growing changes
    assert np.isnan(order) and np.isnan(limit)
    with pytest.raises(ValueError, match="constant ratio"):
        convergence.richardson(np.array([0.004, 0.002, 0.0015]), np.ones(3))
    # factors typed to two digits (1.41, 1, 0.71) are a constant ratio
    convergence.richardson(np.array([1.41, 1.0, 0.71]), np.array([3.0, 2.0, 1.6]))


def test_mesh_levels_scale_every_size_and_hold_the_grid():
    base = cases.load("cases/15_blisk_damper.toml").data
    from microslip.geometry import PARAMETERS

    # the case's values, REFINED's where it has none, else the model's defaults
    params = {"size": PARAMETERS["blisk_sector"]().size, "contact_size": 0.002,
              **convergence.REFINED["blisk_sector"], **base["geometry"]["parameters"]}
    for f in (2.0, 0.5):
        data = convergence.level_data(base, f, None, 3040.0, 3160.0, 0.002)
        cases.check(data, "convergence")
        p = data["geometry"]["parameters"]
        for name in ("size", "blade_size", "contact_size"):
            assert p[name] == pytest.approx(f * params[name])
        assert p["root_size"] == params["root_size"]  # (the corner's own knob: held)
        assert p["blade_layers"] == round(params["blade_layers"] / f)
        assert (p["contact_n_axial"], p["contact_n_flank"]) == (9, 4)  # the model's default
    grid = convergence.level_data(base, 1.0, (12, 6), 3040.0, 3160.0, 0.002)
    assert grid["geometry"]["parameters"]["contact_n_axial"] == 12


def test_a_peak_on_the_window_edge_is_no_frequency():
    data = {"analysis": [{"start": 3100.0, "stop": 3200.0}]}
    assert np.isnan(convergence._inside(3100.0, data))
    assert np.isnan(convergence._inside(3199.5, data))  # within the search grid's step
    assert convergence._inside(3150.0, data) == 3150.0


@pytest.mark.parametrize("args, expected", [
    (["--factors", "1", "0.5"], "three or more positive factors"),
    (["--grids", "9by4"], "is not N1xN2"),
    (["--factors", "2", "1", "0.7", "0.3"], "must be in a constant ratio"),
    (["--start", "3200", "--stop", "3100"], "expected 0 < start < stop"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, args, expected):
    assert main(["bench", "convergence", *args]) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err
