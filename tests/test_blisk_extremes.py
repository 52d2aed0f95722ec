"""The quick blisk case at an extreme a new user tries: friction coefficient 1000 on both
damper flanks (issue 25, section 4). The contacts never slip; only partial lift-off is
nonlinear. At 0.1 N nothing lifts off and the FRF is the fully stuck one; at 1 N the
arclength used to turn back at the lift-off (a sub-sample correction jumped where a stuck
sample preceded an opening one) and ran down its own ascending branch."""

import copy

import h5py
import numpy as np
import pytest

from microslip import case as cases
from microslip.app.run import run_case
from microslip.results.writer import attr_text


def quick(mu: float, amplitude: float, samples: int = 64) -> cases.Case:
    data = copy.deepcopy(cases.load("cases/11_blisk_quick.toml").data)
    data["harmonics"]["samples"] = samples
    for c in data["assembly"]["contacts"]:
        c["mu"] = mu
    data["assembly"]["loads"][0]["amplitude"] = amplitude
    data["analysis"][0].update(maps=["peak"], map_types=["status"])
    return cases.Case(data, "11_blisk_quick.toml")


@pytest.mark.slow
@pytest.mark.parametrize("amplitude", [0.1, 1.0])
def test_the_stuck_blisk_goes_over_its_lift_off_peak(tmp_path, amplitude):
    """0.1 N: the refined peak equals the fully stuck limit's (2.1260e-4 m at 3158.02 rad/s)
    to 1e-6 (Newton's tolerance on a linear response). 1 N: the curve completes, stable at
    every point, no bifurcation; its peak lies below the stuck one (2.126 mm) and left of
    it: partial lift-off softens the stuck resonance a little, single valued (no fold).
    At 1 N the lift-off begins at the peak: 128 samples per period resolve it (at 64 the
    discrete balance has three folds within 2e-3 rad/s and 3e-4 of the amplitude there,
    and the arclength turns back at them: the curve is 'stopped', as it says)."""
    samples = 128 if amplitude > 0.5 else 64
    run_case(quick(1000.0, amplitude, samples), tmp_path, progress=lambda s: None,
             cache=False)
    with h5py.File(tmp_path / "results.h5") as f:
        c, stuck = f["frf/curve_000"], f["frf/linear_stuck"]
        assert c.attrs["status"] == "complete"
        assert c["stable"][()].all() and len(c["bifurcations/kind"]) == 0
        peak = c["maps/point_00"]
        w, top = float(peak.attrs["parameter"]), float(peak["response"][0])
        k = int(np.argmax(stuck["response"][:, 0]))
        w_stuck, top_stuck = stuck["omega"][k], stuck["response"][k, 0]
        if amplitude == 0.1:
            assert top == pytest.approx(2.1260e-4, rel=1e-4)
            assert w == pytest.approx(3158.02, abs=0.1)
        else:
            assert 0.9 * top_stuck < top < 0.97 * top_stuck
            assert w_stuck - 1.0 < w < w_stuck


@pytest.mark.slow
def test_the_light_dampers_fold_has_an_unstable_middle(tmp_path):
    """Firrone & Zucca Fig. 23 right (cases/15_blisk_damper.toml's low_mass: the 3 x damper at
    mu = 1, partial lift-off): two folds located around the frequency the case maps (three
    solutions there), the points between them unstable and their neighbours stable; of the
    three solutions at that frequency (the map points) the middle amplitude is the unstable
    one by Hill's method (3 min)."""
    from microslip.app.models import AssemblyModels
    from microslip.app.stages import mesh_geometry
    from microslip.app.structure import reduce_structure
    from microslip.case import curve_variants
    from microslip.solve.stability import hill_stability

    data = copy.deepcopy(cases.load("cases/15_blisk_damper.toml").data)
    data["analysis"] = [a for a in data["analysis"] if a["name"] == "low_mass"]
    data["analysis"][0]["map_types"] = ["status"]
    (w_fold,) = [m for m in data["analysis"][0]["maps"] if not isinstance(m, str)]
    case = cases.Case(data, "15_blisk_damper.toml")
    run_case(case, tmp_path, progress=lambda s: None, cache=False)
    with h5py.File(tmp_path / "results.h5") as f:
        c = f["low_mass/curve_000"]
        assert c.attrs["status"] == "complete"
        kinds = np.array([k.decode() for k in c["bifurcations/kind"][()]])
        omega = c["bifurcations/omega"][()]
        # the fold pair around w_fold (the FRF's overhang, ~4 rad/s wide); elsewhere the
        # curve has zero-width bifurcation pairs at the kinks where lift-off ends
        folds = (kinds == "fold") & (np.abs(omega - w_fold) < 5.0)
        assert folds.sum() == 2
        i, j = np.sort(c["bifurcations/index"][()][folds])
        stable = c["stable"][()]
        assert stable[i - 5: i + 1].all() and not stable[i + 1: j + 1].any()
        assert stable[j + 1: j + 6].all()
        lo, hi = sorted(omega[folds])
        assert lo < w_fold < hi
        solutions = [c["maps"][p] for p in sorted(c["maps"]) if
                     attr_text(c["maps"][p].attrs["what"]) != "peak"]
        assert len(solutions) == 3
        xs = [p["unknowns"][()] for p in solutions]
        amplitude = [float(p["response"][0]) for p in solutions]
    # the same model, the three solutions' stability
    mesh = mesh_geometry(case.geometry_table, tmp_path, progress=lambda s: None,
                         pictures=False)
    variant = next(iter(curve_variants(case, case.analysis_specs[0])))[0]
    result = reduce_structure(mesh, variant.data["reduction"], None,
                              cases.harmonics(variant).orders, progress=lambda s: None)
    hb = AssemblyModels(mesh, result).model(variant)
    point = cases.operating_point(variant, w_fold)
    verdicts = [hill_stability(hb, x, point).stable for x in xs]
    middle = int(np.argsort(amplitude)[1])
    assert not verdicts[middle] and sum(verdicts) == 2
