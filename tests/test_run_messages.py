"""What a run says (issue 13): warnings for coarse sampling, the cause of a singular solve at
an undamped resonance of a harmonic, cold starts retried by an excitation ramp, and the time
left of long stages."""

import re
from types import SimpleNamespace

import numpy as np
import pytest
from models import jenkins_oscillator

from microslip.pipeline.app import case as cs
from microslip.pipeline.app import structure
from microslip.pipeline.app.results import summary
from microslip.pipeline.app.run import _ticker, run_case, time_left
from microslip.pipeline.solve.hbm import OperatingPoint
from microslip.pipeline.solve.response import resonance_hint, solve_point, sweep

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
    path = run_case(cs.Case(SDOF, "stiff.toml"), tmp_path, progress=lines.append)
    warnings = [line for line in lines if line.startswith("warning:")]
    assert len(warnings) == 1, lines  # the stiff curve only, once
    w = warnings[0]
    assert w.startswith("warning: [frf] curve 2 kt = 1000 N/m: stick arcs within two of the 64 "
                        "samples per period at ")
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


@pytest.mark.parametrize("w", [0.9, 1.1])
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
    tick = _ticker(lines.append, "[frf] curve 1", 0.5, 2.5, clock)
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
    down = _ticker(lines.append, "[frf] curve 2", 2.5, 0.5, clock)  # natural-down
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
