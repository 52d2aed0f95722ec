"""What a run says (issue 13): warnings for coarse sampling, the cause of a singular solve at
an undamped resonance of a harmonic, cold starts retried by an excitation ramp, and the time
left of long stages."""

import re
from types import SimpleNamespace

import numpy as np
import pytest
from models import jenkins_oscillator, normal_oscillator

from microslip import case as cases
from microslip.app import structure
from microslip.app.progress import time_left
from microslip.app.run import run_case
from microslip.app.running import ticker
from microslip.results.writer import summary
from microslip.solve import continuation as cont
from microslip.solve.linear import OperatingPoint
from microslip.solve.response import resonance_hint, sampling_shift, solve_point, sweep

# ------------------------------------------------------------------ undersampled curves
# kt / k = 1e3 against (64 / 2 pi)^2 = 104: every stick arc of the stiff curve falls within
# two samples (the sweep still completes); kt / k = 0.3 is resolved.
SDOF = {
    "title": "stiff wall",
    "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0], "damping": [0.02]},
    "contacts": [{"name": "wall", "law": "A", "kt": 3.0, "mu": 1.0, "n0": 0.05,
                  "u": {"x": 1.0}}],
    "loads": [{"dof": "x", "amplitude": 0.1, "harmonic": 1}],
    "harmonics": {"max": 3, "samples": 64},
    "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.5,
                  "family": {"key": "contacts.wall.kt", "values": [0.3, 1000.0],
                             "label": "kt [N/m]"}}],
}


def test_undersampled_curves_are_warned_once_on_the_terminal_and_in_show(tmp_path):
    lines: list[str] = []
    path = run_case(cases.Case(SDOF, "stiff.toml"), tmp_path, progress=lines.append)
    warnings = [line for line in lines if line.startswith("warning:")]
    assert len(warnings) == 1, lines  # the stiff curve only, once
    w = warnings[0]
    moved = re.match(r"warning: \[frf\] curve 2 kt = 1000 N/m: sampled twice as finely, the "
                     r"curve moves by ([\d.]+) % of the response \(frequency by \S+\) at "
                     r"frequency = [\d.]+: stick arcs within two of the 64 samples per period at "
                     r"\d+ of \d+ points", w)
    assert moved and float(moved[1]) > 0.1  # the threshold: 0.1 % of the response
    n = int(re.search(r"at (\d+) of (\d+) points", w).group(2))
    assert "(contact wall)" in w and n > 10
    assert "raise harmonics.samples from 64, e.g. to 256" in w
    # said after its curve's line, not before
    curve2 = next(i for i, line in enumerate(lines)
                  if re.match(r"\[frf\] curve 2 kt = 1000 N/m: \d+ points, complete", line))
    assert lines.index(w) == curve2 + 1
    shown = summary(path).splitlines()
    flagged = [i for i, line in enumerate(shown) if line.startswith("    warning: ")]
    assert len(flagged) == 1
    assert shown[flagged[0] - 1].startswith("  curve_001 kt = 1000 N/m:")
    assert "raise harmonics.samples from 64, e.g. to 256" in shown[flagged[0]]


# a law-B contact with a gap (Firrone & Zucca Fig. 8): at one point a stick arc falls within
# two of the 256 samples, but the curve does not depend on it (sub-sample transitions locate it)
GAP = {
    "title": "gap",
    "model": {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0], "damping": [0.02]},
    "contacts": [{"name": "wall", "law": "B", "kt": 3.0, "kn": 3.0, "mu": 0.1, "n0": -0.5,
                  "u": {"x": 0.5 ** 0.5}, "v": {"x": 0.5 ** 0.5}}],
    "loads": [{"dof": "x", "amplitude": 0.1, "harmonic": 1}],
    "harmonics": {"max": 5, "samples": 256},
    "analysis": [{"name": "frf", "type": "frf", "start": 0.5, "stop": 2.5}],
}


def test_a_curve_that_does_not_depend_on_its_sampling_is_not_warned(tmp_path):
    lines: list[str] = []
    path = run_case(cases.Case(GAP, "gap.toml"), tmp_path, progress=lines.append)
    assert not [line for line in lines if "warning" in line], lines
    assert "warning" not in summary(path)
    import h5py

    with h5py.File(path) as f:
        c = f["frf/curve_000"]
        flagged = c["contacts/wall/undersampled"][()] > 0
        change = c["sampling_change"][()]
    # checked where flagged (and only there), and found far below the 1e-3 threshold
    assert flagged.any() and np.all(np.isfinite(change[flagged]))
    assert np.all(np.isnan(change[~flagged])) and np.max(change[flagged]) < 1e-4


# ------------------------------------------------- the sampling's a-posteriori estimate
def _fixed_frequency(x):
    return np.append(np.zeros_like(x), 1.0)  # the bordering row that holds the parameter


@pytest.mark.parametrize("fs,P", [(0.02, 0.1), (0.05, 0.5)])
def test_sampling_shift_predicts_the_solution_at_twice_the_samples(fs, P):
    """Against Newton at twice the samples (an independent solve) at every point of a
    Jenkins FRF (H = 7, 128 samples): where the change is 1e-4..1e-2 of the solution (the
    range the 1e-3 warning threshold sits in) the first-order estimate is within 0.7-1.4x
    of it (second-order terms: a relative error of the order of the change itself, plus
    transitions that move across a sample)."""
    hb = jenkins_oscillator(H=7, n_samples=128, fs=fs, P=P)
    r = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
    fine = hb.with_samples(256)
    ratios = []
    for i in range(len(r)):
        x = r.branch.x[i]
        dx, dp = sampling_shift(hb, x, r.point(i), "frequency", _fixed_frequency(x))
        assert dp == pytest.approx(0.0, abs=1e-14)
        true = solve_point(fine, r.point(i), x0=x, settings=cont.Settings(tol=1e-12)).x - x
        if 1e-4 < np.linalg.norm(true) / np.linalg.norm(x) < 1e-2:
            ratios.append(np.linalg.norm(dx) / np.linalg.norm(true))
    assert len(ratios) >= 20 and 0.7 <= min(ratios) and max(ratios) <= 1.4


def test_sampling_shift_stays_finite_at_a_fold_and_points_to_the_finer_branch():
    """At the turning point of the softening law-B oscillator (32 samples, H = 1) the
    Jacobian alone is singular; the shift normal to the branch is not, and it moves the
    point onto the branch computed at twice the samples: the distance to that branch
    (arclength, independent) falls to a small part of what it was."""
    hb = normal_oscillator(0.3, H=1, ns=32)
    arc = sweep(hb, "frequency", 0.5, 2.5, OperatingPoint(0.5))
    fine = sweep(hb.with_samples(64), "frequency", 0.5, 2.5, OperatingPoint(0.5))
    assert arc.branch.complete and fine.branch.complete
    k = arc.branch.turning_points[0]
    dx, dp = arc.sampling_shift(k)
    x, w = arc.branch.x[k], arc.values[k]
    # the continuation's metric: the unknowns by their rms, the parameter by its range
    sx = np.sqrt(np.mean(arc.branch.x ** 2) * arc.branch.x.shape[1])
    span = np.ptp(arc.values)

    def distance(y, v):  # to the finer branch's polyline, in the continuation's metric
        pts = np.column_stack([fine.branch.x / sx, fine.values / span])
        q = np.append(y / sx, v / span)
        a, b = pts[:-1], pts[1:]
        t = np.clip(np.sum((q - a) * (b - a), 1) / np.sum((b - a) ** 2, 1), 0, 1)
        return np.min(np.linalg.norm(a + t[:, None] * (b - a) - q, axis=1))

    before, after = distance(x, w), distance(x + dx, w + dp)
    assert np.all(np.isfinite(dx)) and before > 1e-4
    # first order: the remaining distance is second order in the shift (plus the finer
    # branch's own polyline error between its points)
    assert after < 0.3 * before, (before, after)


# ------------------------------------------------------- resonance of a higher harmonic
def test_singular_jacobian_at_an_undamped_harmonic_resonance_names_the_harmonic():
    """No damping, w = w_n / 3 with harmonics up to 3: order 3 has a zero dynamic stiffness
    and, with the contact slipping, nothing else in its Jacobian block. The message said
    "raise n_samples"; it must name the harmonic, the frequencies and the remedy."""
    hb = jenkins_oscillator(H=3, n_samples=128, c=0.0, P=1.0)
    r = solve_point(hb, OperatingPoint(1 / 3))
    assert not r.converged
    assert r.reason.startswith("singular Jacobian")
    assert "harmonic 3 resonates at w = 0.333333 rad/s" in r.reason
    assert "3 w = 1 rad/s is at the natural frequency 1 rad/s" in r.reason
    assert "add damping or skip this frequency" in r.reason
    assert "raise n_samples" not in r.reason
    # a peak's trial asks only whether it converged: no hint, and no search for it (a
    # whole disk's order block searched for its modes cost ~10 s a failed trial)
    quiet = solve_point(hb, OperatingPoint(1 / 3), x0=r.x, explain=False)
    assert not quiet.converged and "resonates" not in quiet.reason


@pytest.mark.parametrize("H,w,order,natural,state", [
    (5, 1 / 5, 5, 1.0, "free"),  # 5 w = sqrt(k / m)
    (5, 2 / 5, 5, 2.0, "stuck"),  # 5 w = sqrt((k + kt) / m)
    (5, 2 / 3, 3, 2.0, "stuck"),
    (3, (1 + 1e-4) / 3, 3, 1.0, "free"),  # 0.01 % off: measure 2e-4 < 1e-3
])
def test_resonance_hint_finds_the_order_and_the_natural_frequency(H, w, order, natural, state):
    hint = resonance_hint(jenkins_oscillator(H=H, n_samples=128, c=0.0), OperatingPoint(w))
    assert f"harmonic {order} resonates" in hint
    assert f"natural frequency {natural:g} rad/s" in hint and f"contacts {state}" in hint


@pytest.mark.parametrize("c,w", [
    (0.02, 1 / 3),  # damped: 2 zeta = 0.02 at resonance, above the tolerance
    (0.0, 1.01 / 3),  # 1 % off the resonance
    (0.0, 0.3),  # no order near one
])
def test_resonance_hint_is_silent_off_an_undamped_resonance(c, w):
    assert resonance_hint(jenkins_oscillator(H=5, n_samples=128, c=c), OperatingPoint(w)) == ""


# ------------------------------------------------------------- cold starts retried
@pytest.fixture(scope="module")
def stiff():
    """kt / k = 1e4 (resolved by 1024 samples), on the sharp free resonance: the linear
    guesses (free or stuck) are far from the stick-slip solution."""
    return jenkins_oscillator(H=5, n_samples=1024, kt=1e4, P=0.1)


@pytest.mark.parametrize("w", [pytest.param(0.9, marks=pytest.mark.slow), 1.1])  # (below
# the resonance the same ramp: slow)
def test_a_failed_cold_start_is_reached_by_an_excitation_ramp(stiff, w):
    p = OperatingPoint(w)
    cold = solve_point(stiff, p, retry=False)
    assert not cold.converged  # the plain cold start fails here
    r = solve_point(stiff, p)
    assert r.converged, r.reason
    assert "the cold start failed" in r.reason
    assert "continuation in the excitation from 0.001 x" in r.reason
    # the solution continuation in frequency reaches from w = 0.5, where a cold start works:
    # both satisfy ||R|| <= 1e-9 x 0.1 N, and the Jacobian's inverse (<= ~1e2 m/N even at
    # the free resonance, c w = 0.02) maps that to < 1e-8 m; 1e-6 of the amplitude is safe
    # and far below any other solution (the branch is single-valued)
    ref = sweep(stiff, "frequency", 0.5, w, OperatingPoint(0.5))
    assert ref.branch.complete and ref.values[-1] == w
    np.testing.assert_allclose(r.x, ref.branch.x[-1], rtol=0,
                               atol=1e-6 * np.max(np.abs(ref.branch.x[-1])))


def test_a_sweep_whose_first_point_fails_starts_from_the_ramp(stiff):
    plain = sweep(stiff, "frequency", 1.1, 1.2, OperatingPoint(1.1), retry=False)
    assert len(plain) == 0 and plain.branch.message.startswith("no solution at frequency = 1.1")
    r = sweep(stiff, "frequency", 1.1, 1.2, OperatingPoint(1.1))
    assert r.branch.complete and len(r) > 1
    assert r.branch.message.startswith("first point: the cold start failed, reached by natural "
                                       "continuation in the excitation")
    np.testing.assert_allclose(r.branch.x[0], solve_point(stiff, OperatingPoint(1.1)).x,
                               rtol=0, atol=1e-6 * np.max(np.abs(r.branch.x[0])))


def test_a_ramp_that_fails_says_what_was_tried(stiff):
    r = solve_point(stiff, OperatingPoint(1.0))  # the ramps stop at a corner near 0.69 x
    assert not r.converged
    assert "retried by continuation in the excitation from 0.001 x its value: natural " \
           "reached 0.69" in r.reason
    assert "arclength reached" in r.reason and "a sweep in frequency" in r.reason


# ------------------------------------------------------------------------- time left
@pytest.mark.parametrize("elapsed,fraction,text", [
    (10.0, 0.5, "~10 s left"),
    (3.0, 0.1, "~27 s left"),
    (60.0, 0.25, "~3 min left"),  # 180 s
    (3600.0, 0.25, "~3.0 h left"),
    (5.0, 0.0, ""),  # no progress yet: no rate
    (5.0, 1.0, ""),  # done
    (0.0, 0.5, ""),
])
def test_time_left_from_the_rate_so_far(elapsed, fraction, text):
    assert time_left(elapsed, fraction) == text


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_continuation_ticks_show_the_range_covered_and_the_time_left():
    clock, lines = FakeClock(), []
    tick = ticker(lines.append, "[frf] curve 1", 0.5, 2.5, clock)
    clock.t += 0.2
    tick(1, 0.5, 3)  # the first point: shown, nothing covered yet
    for n, (dt, value) in enumerate([(0.3, 0.6), (0.3, 0.7), (0.6, 1.0), (0.5, 1.1)], 2):
        clock.t += dt
        tick(n, value, 4)
    assert lines == [
        "[frf] curve 1 point 1, value 0.5 (0% of the range), 3 Newton iterations",
        # 1.4 s after the start, 25 % covered: 4.2 s to go (at most one line a second)
        "[frf] curve 1 point 4, value 1 (25% of the range, ~4 s left), 4 Newton iterations",
    ]
    clock.t += 0.6
    tick(6, 0.9, 5)  # arclength turned back at a fold: the farthest reached (30 %) counts
    assert lines[-1] == ("[frf] curve 1 point 6, value 0.9 (30% of the range, ~6 s left), "
                         "5 Newton iterations")  # 2.5 s x 0.7 / 0.3
    clock.t += 1.1
    tick(7, 1.5, 4)
    assert lines[-1] == ("[frf] curve 1 point 7, value 1.5 (50% of the range, ~4 s left), "
                         "4 Newton iterations")  # 3.6 s x 0.5 / 0.5
    down = ticker(lines.append, "[frf] curve 2", 2.5, 0.5, clock)  # natural-down
    clock.t += 2.0
    down(3, 2.0, 2)
    assert lines[-1].endswith("(25% of the range, ~6 s left), 2 Newton iterations")


def test_reduction_lines_count_models_and_show_the_time_left():
    clock, lines = FakeClock(), []
    count = structure._Count(3, clock)  # blisk ND 0, ND 3 and the damper
    result = structure.StructureResult({}, {}, (0, 3), None)
    model = SimpleNamespace(n_masters=12, n_modes=4,
                            frequencies=lambda n: np.arange(1.0, n + 1) * 100.0)
    blisk = structure._recorder(result, "blisk", None, lines.append, count)
    damper = structure._recorder(result, "damper", (0, 3), lines.append, count)
    clock.t += 10.0
    blisk(0, model, None, False, 10.0)
    clock.t += 10.0
    blisk(3, model, None, False, 10.0)
    clock.t += 1.0
    damper(0, model, None, True, 0.0)
    assert lines[0].startswith("[reduction] blisk ND 0 (1/3, ~20 s left): 12 master DOFs")
    assert lines[1].startswith("[reduction] blisk ND 3 (2/3, ~10 s left): ")
    assert lines[2].startswith("[reduction] damper (3/3): 12 master DOFs + 4 modes, from cache")


@pytest.mark.parametrize("law", ["A", "B"])
def test_a_curve_without_a_start_point_fails_in_one_line_and_the_run_goes_on(tmp_path, law):
    """A tolerance no Newton meets: no start point, coupled (law A's static forces) or
    uncoupled (law B's N0); the curve is failed with 0 points, written, never a traceback,
    and the next analysis still runs."""
    import copy

    import h5py

    data = copy.deepcopy(SDOF)
    data["contacts"][0] |= {"law": law} | ({"kn": 3.0, "v": {"x": 1.0}} if law == "B" else {})
    data["solver"] = {"tol": 1e-30, "max_iter": 1}
    data["analysis"] = [{"name": "none", "type": "frf", "start": 0.5, "stop": 2.5},
                        {"name": "loops", "type": "loops", "contact": "wall",
                         "u": [0.1, 0.0], "amplitudes": [1.0]} | (
                            {"v": [0.0, 0.0]} if law == "B" else {})]
    lines: list[str] = []
    path = run_case(cases.Case(data, "none.toml"), tmp_path, progress=lines.append)
    with h5py.File(path) as f:
        curve = f["none/curve_000"]
        assert curve.attrs["status"] == "failed" and len(curve["omega"]) == 0
        assert f["loops"].attrs["status"] == "complete"
        assert f.attrs["status"] == "partial"
    failed = [line for line in lines if "0 points, failed" in line]
    assert len(failed) == 1 and "found no start" in failed[0]


def test_a_ramp_that_reaches_the_load_but_not_its_polish_says_so(monkeypatch):
    """The excitation ramp's continuation reaches the full load but Newton at the exact
    point then fails: the message says that, with Newton's reason (it read "reached 1 x",
    as if the ramp had stopped short)."""
    from microslip.solve import response

    model = jenkins_oscillator(H=1, n_samples=16)
    real = cont.newton

    def failing(fun, x0, lam, **kw):  # the polish at the exact load fails
        r = real(fun, x0, lam, **kw)
        return cont.NewtonResult(r.x, False, r.iterations, r.residual, "stalled (test)")

    monkeypatch.setattr(response.cont, "newton", failing)
    found, message = response.excitation_ramp(model, OperatingPoint(1.0))
    assert found is None
    # (natural's own start fails with the patched Newton; arclength starts otherwise)
    assert "arclength reached the full value, where Newton then failed (stalled (test))" \
        in message
