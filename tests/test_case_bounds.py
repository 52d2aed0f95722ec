"""Case inputs bounded before the work starts (issue 13, section 3): the samples rule, the
memory of the harmonic balance, and a note where the sampling limits stiff contacts."""

import copy
import re
from pathlib import Path

import pytest
from case_helpers import case_faults

from microslip import case as cases
from microslip.case import estimate
from microslip.cli import main
from microslip.fourier import Harmonics, least_samples
from microslip.solve.hbm import HarmonicBalance

CASES = Path(__file__).parents[1] / "cases"

SDOF = {  # cases/01_sdof_wall.toml in short: m = 1, k = 1, a wall of law A
    "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0], "damping": [0.02]},
    "contacts": [{"name": "wall", "law": "A", "kt": 3.0, "mu": 1.0, "n0": 0.05,
                  "u": {"x": 1.0}}],
    "loads": [{"dof": "x", "amplitude": 0.1}],
    "harmonics": {"max": 1, "samples": 128},
    "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.5}],
}
LOOPS = {"name": "loops", "type": "loops", "contact": "wall", "u": [1.0, 0.0],
         "amplitudes": [0.5, 2.0]}


def sdof(**harmonics) -> dict:
    data = copy.deepcopy(SDOF)
    data["harmonics"] = harmonics
    return data


@pytest.fixture
def memory(monkeypatch):
    """The available memory the check compares with, fixed (bytes)."""
    def fix(nbytes):
        monkeypatch.setattr(estimate, "available_memory", lambda: nbytes)
    fix(64e9)
    return fix


# ---------------------------------------------------------------- samples per period
def test_rule_smallest_samples():
    assert [least_samples(h) for h in (0, 1, 3, 7, 8, 10000)] == [16, 32, 64, 128, 256, 262144]


@pytest.mark.parametrize("samples,why,hint", [
    (3, "too few for order 1 and not a power of two", "the smallest is 32"),
    (100, "not a power of two", "the smallest is 32, the nearest above 100 is 128"),
    (16, "too few for order 1", "the smallest is 32"),
])
def test_samples_off_the_rule_are_refused(samples, why, hint):
    found = case_faults(SDOF, lambda d: d["harmonics"].update(samples=samples))
    assert found == [f"harmonics.samples = {samples}: {why}; allowed: a power of two >= "
                     f"16 (H + 1) = 32 for the highest harmonic H = 1; {hint}"]


def test_samples_rule_follows_the_highest_order():
    found = case_faults(SDOF, lambda d: d.update(harmonics={"orders": [1, 3, 5],
                                                            "samples": 64}))
    assert any("harmonics.samples = 64: too few for order 5" in f and "= 96" in f
               and "the smallest is 128" in f for f in found), found


@pytest.mark.parametrize("harmonics", [
    {"max": 1, "samples": 32}, {"max": 1, "samples": 1024}, {"max": 3, "samples": 64},
    {"orders": [1, 3, 5], "samples": 128}, {"max": 10}])  # the default follows the rule
def test_samples_on_the_rule_are_accepted(harmonics, memory):
    cases.check(sdof(**harmonics))


def test_loops_samples_follow_the_rule():
    def loops(samples):
        return lambda d: d["analysis"].append({**LOOPS, "samples": samples})

    found = case_faults(SDOF, loops(100))
    assert any(f.startswith("analysis.loops.samples = 100: not a power of two") for f in found)
    found = case_faults(SDOF, loops(16))
    assert any("analysis.loops.samples = 16: too few for order 1" in f for f in found)
    data = copy.deepcopy(SDOF)
    loops(64)(data)
    cases.check(data)


def test_set_and_family_harmonics_follow_the_rule():
    """An analysis that raises H over the case's samples gets the same refusal."""
    found = case_faults(SDOF, lambda d: d["analysis"][0].update(set={"harmonics.max": 8}))
    assert any(f.startswith("analysis.frf.set: harmonics.samples = 128: too few for order 8")
               for f in found), found
    found = case_faults(SDOF, lambda d: d["analysis"][0].update(
        family={"key": "harmonics.max", "values": [1, 3, 9]}))
    assert any(f.startswith("analysis.frf.family.values[2]: harmonics.samples = 128: too few "
                            "for order 9") for f in found), found
    assert not any("values[0]" in f or "values[1]" in f for f in found), found


@pytest.mark.parametrize("argv,msg", [
    (["--samples", "100"], "--samples = 100: too few for order 7 and not a power of two"),
    (["--harmonics", "3", "--samples", "96"], "--samples = 96: not a power of two"),
    (["--harmonics", "3", "--samples", "32"], "the smallest is 64"),
    (["--harmonics", "0"], "--harmonics = 0: expected an integer >= 1"),
])
def test_demo_refuses_samples_off_the_rule(capsys, argv, msg):
    assert main(["demo", *argv]) == 2  # before any sweep
    captured = capsys.readouterr()
    assert msg in captured.err and captured.out == ""


# ---------------------------------------------------------------- memory
def test_memory_refusal_before_anything_is_built(monkeypatch, memory):
    memory(16e9)

    def built(*args, **kwargs):
        raise AssertionError("the check built a model")

    monkeypatch.setattr(HarmonicBalance, "__init__", built)
    monkeypatch.setattr(Harmonics, "synthesis", property(built))
    with pytest.raises(cases.CaseError) as err:
        cases.check(sdof(max=10000))
    (fault,) = err.value.faults
    assert fault.startswith("analysis.frf: needs ~")
    assert "(20,001 real unknowns: 1 contact DOF(s) x 20,001 coefficients, H = 10000, " \
           "262,144 samples per period) but 16.0 GB of memory is available" in fault
    assert "lower harmonics.max" in fault
    need = float(fault.split("needs ~")[1].split(" GB")[0])
    assert need > 100  # the synthesis and analysis matrices alone: 2 x 262,144 x 20,001 x 8 B


def test_memory_refusal_stops_run_before_its_folder(tmp_path, capsys, memory):
    memory(16e9)
    text = (CASES / "01_sdof_wall.toml").read_text().replace("max = 1 ", "max = 10000 ")
    text, n = re.subn(r"(?m)^samples = \d+", "samples = 262144", text)
    assert n == 1  # the shipped case sets its samples: the test must change them
    case = tmp_path / "big.toml"
    case.write_text(text)
    assert main(["run", str(case), "--out", str(tmp_path / "o")]) == 2
    assert "needs ~" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    assert main(["check", str(case)]) == 2


def test_the_estimate_counts_unknowns_and_grows_with_harmonics(memory):
    small, big = (cases.sizes(sdof(max=h))[0] for h in (1, 300))
    assert (small.unknowns, big.unknowns) == (3, 601)
    assert small.nbytes < 1e6 < 0.5e9 < big.nbytes < 1e9  # 601: ~0.7 GB measured (peak RSS)
    data = copy.deepcopy(SDOF)
    data["analysis"].append({**LOOPS})
    assert cases.sizes(data)[1].unknowns == 0


def test_family_variants_are_estimated():
    data = sdof(max=1)
    data["analysis"][0]["family"] = {"key": "harmonics.max", "values": [1, 5]}
    assert cases.sizes(data)[0].unknowns == 11


def test_rerun_checks_skip_the_memory_bound(memory):
    """A run's curves re-check their case (set, family): not against memory its own arrays
    already took; load bounded them all."""
    c = cases.Case(copy.deepcopy(SDOF), "t.toml")
    memory(1)
    assert c.with_values({"contacts.wall.n0": 0.1}).data["contacts"][0]["n0"] == 0.1
    with pytest.raises(cases.CaseError, match="of memory is available"):
        cases.check(c.data)


def test_check_prints_the_estimate_of_shipped_cases(capsys, memory):
    assert main(["check", str(CASES / "15_blisk_damper.toml"),
                 str(CASES / "01_sdof_wall.toml")]) == 0
    out = capsys.readouterr().out.splitlines()
    # 2 patches x 9 x 4 node pairs x 2 nodes x 3 DOFs = 432 contact DOFs, x 3 coefficients
    assert out[0].endswith("(4 analyses: frf, optimization, optimization_from_modes, "
                           "low_mass; largest analysis: optimization_from_modes, 1,296 "
                           "unknowns, ~0.6 GB)")
    assert out[1].endswith("largest analysis: frf_N0, 3 unknowns, <1 MB)")


# ---------------------------------------------------------------- stiff contacts
@pytest.mark.parametrize("kt", [1e6, 1e12])
def test_stiff_contact_gets_a_note(capsys, tmp_path, kt):
    data = sdof(max=1, samples=128)
    data["contacts"][0]["kt"] = kt
    (note,) = cases.notes(data)
    assert note.startswith(f"contacts.wall.kt = {kt:g} N/m is {kt:.3g} x the structure's "
                           "stiffness along u (1 N/m), above (samples / 2 pi)^2 = 415 for 128 "
                           "samples")
    assert "harmonics.samples = 8,192 would resolve it" in note or kt != 1e6
    case = tmp_path / "stiff.toml"
    text = (CASES / "01_sdof_wall.toml").read_text().replace("kt = 3.0 ", f"kt = {kt:g} ")
    case.write_text(text)
    assert main(["check", str(case)]) == 0  # a note, not a fault
    assert f"{case}: note: contacts.wall.kt = {kt:g}" in capsys.readouterr().out


def test_no_note_below_the_sampling_limit():
    data = sdof(max=1, samples=128)
    data["contacts"][0]["kt"] = 400.0  # (128 / 2 pi)^2 = 415
    assert cases.notes(data) == []
    data["harmonics"]["samples"] = 64  # (64 / 2 pi)^2 = 104
    assert len(cases.notes(data)) == 1
    for name in ("06_blade_damper", "03_normal_load", "04_plane_circular", "01_sdof_wall"):
        assert cases.notes(cases.load(CASES / f"{name}.toml").data) == [], name


def test_an_unknown_jacobian_is_one_line_naming_the_choices():
    data = sdof(max=1)
    data["solver"] = {"jacobian": "lu"}
    with pytest.raises(cases.CaseError) as err:
        cases.check(data)
    assert err.value.faults == ["solver.jacobian = 'lu': expected one of 'auto', 'dense', "
                                "'structured'"]
