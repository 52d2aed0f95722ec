"""Case files: every fault named before any work; runs write what they promise."""

import copy
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest
from case_helpers import TWO_DOF, case_faults

from microslip import case as cases
from microslip.app.run import run_case

CASES = Path(__file__).parents[1] / "cases"

GOOD = TWO_DOF


def faults(mutate) -> list[str]:
    return case_faults(GOOD, mutate)


def test_good_case_builds_the_model_it_says():
    cases.check(GOOD)
    c = cases.Case(GOOD, "t.toml")
    hb = cases.lumped_model(c)
    assert hb.harmonics.orders == (0, 1, 2, 3) and hb.harmonics.n_samples == 64
    assert np.allclose(hb.linear.K[0].real, [[2, -1], [-1, 2]])
    assert np.allclose(hb.linear.M[1].real, np.diag([1.0, 2.0]))
    B = hb.contacts[0].kinematics
    assert np.allclose(B, [[1.0, 0.0], [-0.5, 1.0]])  # rows u, v from named DOFs
    assert hb.F_ext[1][0] == pytest.approx(0.1)


@pytest.mark.parametrize(
    "mutate,expected",
    [
        (lambda d: d.update(colour=1), "colour: unknown key"),
        (lambda d: d["model"].pop("mass"), "model.mass: missing"),
        (lambda d: d["model"].update(mass=[1.0, -2.0]), "diagonal values must be > 0"),
        (lambda d: d["model"].update(mass=[[1.0, 0.5], [0.0, 1.0]]), "not symmetric"),
        (lambda d: d["model"].update(stiffness="stiff"), "model.stiffness = 'stiff'"),
        (lambda d: d["contacts"][0].update(u={"z": 1.0}), "contacts.c.u.z: unknown DOF"),
        (lambda d: d["contacts"][0].update(mu=-0.1), "contacts.c.mu = -0.1: must be >= 0"),
        (lambda d: d["contacts"][0].update(law="E"), "contacts.c.law = 'E'"),
        (lambda d: d["contacts"][0].pop("kn"), "contacts.c.kn: missing"),
        (lambda d: d["contacts"][0].update(form="coupled"), "takes 'interference'"),
        (lambda d: d["loads"][0].update(dof="q"), "loads[0].dof = 'q'"),
        (lambda d: d["harmonics"].update(samples=5), "too few for order 3"),
        (lambda d: d["analysis"][0].update(stop=0.5), "zero length"),
        (lambda d: d["analysis"][0].update(type="fly"), "analysis[0].type = 'fly'"),
        (lambda d: d["analysis"][0].update(family={"key": "contacts.c.zz", "values": [1]}),
         "no such key"),
        (lambda d: d.pop("analysis"), "analysis: missing"),
        # a load on an order the balance does not compute would drive nothing, 'complete'
        (lambda d: d["harmonics"].update(max=0),
         "loads[0].harmonic = 1: that order is not computed (harmonics.max = 0: orders [0])"),
        (lambda d: d.update(harmonics={"orders": [0, 3], "samples": 64}),
         "loads[0].harmonic = 1: that order is not computed (harmonics.orders = [0, 3])"),
        (lambda d: d["loads"][0].update(harmonic=5), "loads[0].harmonic = 5: that order is "
         "not computed (harmonics.max = 3: orders [0, 1, 2, 3]), so the load would drive "
         "nothing; raise harmonics.max to 5"),
        (lambda d: d["analysis"][0].update(set={"harmonics.max": 0}),
         "analysis.a.set: loads[0].harmonic = 1: that order is not computed"),
        # two analyses of one name would write one results group twice
        (lambda d: d["analysis"].append(dict(d["analysis"][0])),
         "analysis[1].name = 'a': analysis[0] has that name already"),
        (lambda d: d["analysis"][0].update(name="reduction"),
         "analysis[0].name = 'reduction': reserved"),
        (lambda d: d["analysis"][0].update(name="a/b"), "analysis[0].name = 'a/b': expected"),
    ],
)
def test_each_fault_is_named(mutate, expected):
    found = faults(mutate)
    assert any(expected in f for f in found), found


def test_all_faults_reported_at_once():
    def many(d):
        d["model"]["mass"] = [1.0, 0.0]
        d["contacts"][0]["mu"] = -1
        d["loads"][0]["dof"] = "nope"
    assert len(faults(many)) == 3


def test_shipped_cases_are_valid():
    paths = sorted(CASES.glob("*.toml"))
    assert paths
    for path in paths:
        cases.load(path)  # raises CaseError naming every fault


def test_run_writes_results_and_pictures(tmp_path):
    data = copy.deepcopy(GOOD)
    data["analysis"].append({"name": "loops", "type": "loops", "contact": "c",
                             "u": [1.0, 0.0], "v": [0.2, 0.0], "amplitudes": [0.5, 2.0]})
    data["analysis"][0]["family"] = {"key": "contacts.c.n0", "values": [0.2, 0.5]}
    path = run_case(cases.Case(data, "t.toml"), tmp_path, progress=lambda m: None)
    assert path == tmp_path / "results.h5" and not (tmp_path / "results.h5.tmp").exists()
    with h5py.File(path) as f:
        assert f.attrs["status"] == "complete"
        assert set(f) == {"case", "a", "loops"}
        for curve, n0 in (("curve_000", 0.2), ("curve_001", 0.5)):
            g = f["a"][curve]
            assert g.attrs["family_value"] == n0
            n = g["parameter"].shape[0]
            assert g["amplitude"].shape == (n, 2) and g["coefficients"].shape == (n, 2, 7)
            assert np.all(g["residual"][()] <= 1e-9)
            assert g["contacts/c/state"].shape == (n,)
        assert f["loops/curve_000/T"].shape == (2, 1, 512)
    assert (tmp_path / "a_x.png").stat().st_size > 0 and (tmp_path / "loops.png").exists()


def test_interrupted_run_leaves_a_valid_partial_file(tmp_path):
    data = copy.deepcopy(GOOD)
    data["analysis"][0]["family"] = {"key": "contacts.c.n0", "values": [0.2, 0.5, 0.8]}
    calls = []

    def progress(msg):
        calls.append(msg)
        if "curve 1" in msg and ": " in msg and "points" in msg:
            raise KeyboardInterrupt

    # the interrupt (at the line that reports curve 1 written) ends the analysis's curves
    run_case(cases.Case(data, "t.toml"), tmp_path, progress=progress)
    assert not (tmp_path / "results.h5.tmp").exists()
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["status"] == "partial"
        assert f.attrs["message"].startswith("interrupted")
        assert "curve_000" in f["a"] and "curve_001" not in f["a"]


def test_a_stopped_curve_makes_the_run_partial_and_exit_1(tmp_path, monkeypatch):
    """A curve cut short (3 points cannot cover 0.5..2 rad/s) is not a complete run:
    the file says partial and which analysis stopped, and `microslip run` exits 1."""
    from microslip import cli

    data = copy.deepcopy(GOOD)
    data["solver"] = {"max_points": 3}
    cases.check(data)
    monkeypatch.setattr(cli.run_command, "load_case", lambda cmd, path: cases.Case(data, "t.toml"))
    assert cli.main(["run", "t.toml", "--out", str(tmp_path)]) == 1
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["status"] == "partial"
        assert f.attrs["message"].startswith("analysis a stopped")
        assert f["a"].attrs["status"] == "stopped"
    data.pop("solver")  # the same case through to the end: exit 0
    assert cli.main(["run", "t.toml", "--out", str(tmp_path)]) == 0


def test_transient_and_dti_analyses(tmp_path):
    """A mass pressed on a wall by a static load (law B, no preload): after the
    quasi-static step N equals the load; time integration runs from a case."""
    data = {
        "title": "pressed mass",
        "model": {"dofs": ["x", "y"], "mass": [1.0, 1.0], "stiffness": [1.0, 1.0],
                  "damping": [0.05, 2.0]},  # y settles in ~1 s (zeta 0.14)
        "contacts": [{"name": "wall", "law": "B", "kt": 5.0, "kn": 50.0, "mu": 0.5, "n0": 0.0,
                      "u": {"x": 1.0}, "v": {"y": 1.0}}],
        "loads": [{"dof": "y", "amplitude": 2.0, "harmonic": 0},
                  {"dof": "x", "amplitude": 0.2, "harmonic": 1}],
        "harmonics": {"max": 1, "samples": 64},
        "analysis": [
            {"name": "steps", "type": "transient", "frequency": 2.0, "ramp_time": 3.0,
             "settle_time": 20.0, "ramp_periods": 2, "steps_per_period": 64},
            {"name": "time", "type": "dti", "frequencies": [1.5, 2.5], "ramp_time": 3.0,
             "settle_time": 20.0, "ramp_periods": 2, "steps_per_period": 64},
        ],
    }
    run_case(cases.Case(data, "t.toml"), tmp_path, progress=lambda m: None)
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["status"] == "complete"
        N = f["steps/step_1/contacts/wall/N"][()]
        # static balance of y: (k + kn) y = 2 N with the wall's kn: N = kn y = 2 kn / (1 + kn)
        assert N[-1, 0] == pytest.approx(2.0 * 50.0 / 51.0, rel=1e-4)
        assert f["time/curve_000/amplitude"].shape == (2, 2)
        assert np.all(f["time/curve_000/converged"][()])
    assert (tmp_path / "steps.png").exists() and (tmp_path / "time_x.png").exists()


def test_linear_model_and_response_measures(tmp_path):
    """No contact: the sweep samples the linear FRF; its peak sits on an
    eigenfrequency of (K, M); 'vibration' removes the static deflection."""
    data = copy.deepcopy(GOOD)
    data["contacts"][0]["enabled"] = False
    data["loads"].append({"dof": "x", "amplitude": 0.5, "harmonic": 0})
    data["analysis"][0]["measure"] = "vibration"
    run_case(cases.Case(data, "t.toml"), tmp_path, progress=lambda m: None)
    K, M = np.array([[2.0, -1.0], [-1.0, 2.0]]), np.diag([1.0, 2.0])
    w_modes = np.sqrt(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    with h5py.File(tmp_path / "results.h5") as f:
        g = f["a/curve_000"]
        w, peak, vib = g["omega"][()], g["amplitude"][:, 0], g["response"][:, 0]
        x0 = np.linalg.solve(K, [0.5, 0.0])[0]  # static deflection of x
        # grid spacing 1.5 / 800: the sampled resonance within two steps of a mode
        assert np.min(np.abs(w[np.argmax(vib)] - w_modes)) < 2 * 1.5 / 800
        assert np.allclose(peak, vib + abs(x0), rtol=1e-9)  # harmonic 1 only: |x| = |x0| + |x1|


def test_the_old_coupling_table_is_read_as_assembly_with_a_note(tmp_path, capsys):
    # [coupling] was renamed [assembly] ("coupled" is the contact form of eqs. 24-28):
    # an old file still runs, read as the new table, and check says to rename it
    from microslip.cli import main

    new = (Path(__file__).parents[1] / "cases" / "15_blisk_damper.toml").read_text()
    assert "[assembly]" in new and "coupling" not in new and '"assembly.' in new
    old = tmp_path / "old.toml"  # the tables and the dotted key paths under the old name
    old.write_text(new.replace("[assembly", "[coupling").replace('"assembly.', '"coupling.'))
    assert cases.load(old).data == tomllib.loads(new)
    assert main(["check", str(old)]) == 0
    out = capsys.readouterr().out
    assert "note: [coupling] is now called [assembly] (read as [assembly]); rename" in out
    both = tmp_path / "both.toml"
    both.write_text(new + "\n[coupling]\nexcitation = 1.0\n")
    with pytest.raises(cases.CaseError) as err:
        cases.load(both)
    assert err.value.faults == ["[coupling] and [assembly]: [coupling] is the old name of "
                                "[assembly]; give [assembly] only"]


def test_a_dti_without_compare_is_valid():
    # compare's default is "" (nothing drawn with it), not a name to look up
    data = copy.deepcopy(TWO_DOF)
    data["analysis"] = [{"name": "steady", "type": "dti", "frequencies": [1.0]}]
    cases.check(data)
    data["analysis"][0]["compare"] = "nowhere"
    with pytest.raises(cases.CaseError) as err:
        cases.check(data)
    assert err.value.faults == ["analysis.steady.compare = 'nowhere': no analysis of that "
                                "name; known: ['steady']"]


def test_reserved_analysis_names_are_the_results_file_s_groups():
    from microslip.case.faults import RESERVED
    from microslip.results import schema

    assert set(RESERVED) == {schema.CASE, schema.GEOMETRY, schema.CONTACT_GRIDS,
                             schema.SURFACES, schema.REDUCTION}


def test_an_unnamed_analysis_is_estimated_under_its_name(tmp_path):
    """An [[analysis]] without a name is 'analysis<i>' everywhere: the estimate found it
    under '<i>' and the run and dry run ended in StopIteration."""
    from microslip.app import plan
    from microslip.case.estimate import task_seconds

    data = copy.deepcopy(GOOD)
    del data["analysis"][0]["name"]
    cases.check(data)
    c = cases.Case(data, "t.toml")
    (spec,) = c.analysis_specs
    assert spec.name == "analysis0" and [s.analysis for s in cases.sizes(data)] == ["analysis0"]
    assert task_seconds(data, spec) > 0
    assert any(s.name.startswith("analysis0: curve 1") for s in plan.plan(c, tmp_path))
