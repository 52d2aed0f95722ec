"""`microslip render` redraws every picture a run draws, from results.h5 alone: the same
files, pixel for pixel (matplotlib draws the same data the same way); what the run writes
follows the results layout."""

import copy

import h5py
import matplotlib.image as mpimg
import numpy as np
from case_helpers import TWO_DOF

from microslip import case as cases
from microslip.app.run import run_case
from microslip.case.kinds import shipped
from microslip.cli import main
from microslip.draw.pictures import analysis_spec
from microslip.results import schema

# the 2-DOF law-B case (variable normal load), more damped, with every lumped analysis type;
# the time integration is compared with the FRF
EVERY_KIND = copy.deepcopy(TWO_DOF) | {"title": "every picture", "analysis": [
    {"name": "curve", "type": "frf", "start": 0.8, "stop": 1.2, "outputs": ["x"]},
    {"name": "loops", "type": "loops", "contact": "c", "u": [1.0, 0.0], "v": [0.5, 0.0],
     "amplitudes": [0.5, 2.0]},
    {"name": "steady", "type": "dti", "frequencies": [0.9, 1.1], "outputs": ["x"],
     "steps_per_period": 64, "ramp_periods": 20, "max_periods": 200, "compare": "curve"},
    {"name": "steps", "type": "transient", "frequency": 1.0, "outputs": ["x", "y"],
     "steps_per_period": 64, "ramp_periods": 5},
    {"name": "top", "type": "peak", "parameter": "excitation", "start": 0.5, "stop": 1.0,
     "points": 3, "window": [0.8, 1.2], "output": "x"},
    {"name": "spread", "type": "uncertainty", "window": [0.8, 1.2], "output": "x",
     "samples": 4, "limit": 0.5, "parameters": {"mu": {"uniform": [0.2, 0.4]}}},
    {"name": "backbone", "type": "nonlinear_modes", "output": "x", "amplitude": [0.01, 1.0],
     "excitations": [1.0], "family": {"key": "contacts.0.n0", "values": [0.5, 0.7]}},
]}
EVERY_KIND["model"]["damping"] = [0.05, 0.05]


def test_render_redraws_every_picture_of_every_analysis_type(tmp_path):
    # every analysis type of a lumped case (the mesh previews of a meshed case:
    # test_assembly_case; the modes of reduced bodies: test_modes; the whole disk's
    # mistuning study: test_mistuned_case)
    assert {a["type"] for a in EVERY_KIND["analysis"]} == set(shipped()) - {"modes",
                                                                          "mistuning"}
    run = tmp_path / "run"
    path = run_case(cases.Case(copy.deepcopy(EVERY_KIND), "every.toml"), run,
                    progress=lambda m: None)
    drawn = sorted(p.name for p in run.glob("*.png"))
    # one picture per analysis at least, the dti's per output and per contact
    assert {"curve_x.png", "loops.png", "steady_x.png", "steady_static_c.png",
            "steps.png", "top.png", "spread.png", "spread_parameters.png",
            "backbone_frequency.png", "backbone_damping.png", "backbone_peaks.png",
            "backbone_frf.png", "backbone_optimization.png"} <= set(drawn)
    with h5py.File(path) as f:  # every object written is in the layout (results/schema.py)
        assert schema.undescribed(f) == []
        # the record of each analysis reads back as its spec (what the drawers use)
        for spec in cases.Case(copy.deepcopy(EVERY_KIND), "every.toml").analysis_specs:
            assert analysis_spec(f[spec.name]).table() == spec.table()
    again = tmp_path / "again"
    assert main(["render", str(path), "--out", str(again)]) == 0
    assert sorted(p.name for p in again.glob("*.png")) == drawn
    for name in drawn:
        np.testing.assert_array_equal(mpimg.imread(again / name), mpimg.imread(run / name),
                                      err_msg=name)
