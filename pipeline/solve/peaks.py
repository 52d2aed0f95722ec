"""Peak curves: the largest response over a frequency window against a parameter (the
optimization and performance curves of Firrone & Zucca Fig. 6), the peak tracked from
value to value, and Hill's stability of a peak's solution."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from . import continuation as cont
from .hbm import HarmonicBalance
from .linear import OperatingPoint
from .response import (
    dof_rows,
    measure_of,
    output,
    refine_peak,
    response_measure,
    solve_point,
    sweep,
)
from .stability import Stability, hill_stability, undefined


@dataclass
class PeakCurve:
    """The largest response of one DOF over a frequency window, against a parameter.

    values: (n,) parameter; omega: (n,) rad/s at the peak; amplitude: (n,)
    max|x(t)| there, m; how: per point "swept" (a full FRF over the window) or
    "tracked" (continuation of the previous peak); solves: Newton solves in all."""

    values: np.ndarray
    omega: np.ndarray
    amplitude: np.ndarray
    how: list[str]
    solves: int
    #: per point Hill's stability at the peak (``stability``), else None
    stability: list[Stability | None] | None = None


def peak_curve(
    model: HarmonicBalance,
    parameter: str,
    values,
    dof: int | np.ndarray,
    window: tuple[float, float],
    base: OperatingPoint | None = None,
    *,
    settings: cont.Settings = cont.DEFAULT,
    progress: Callable[[int, float, float, float, str], None] | None = None,
    vibration: bool = False,
    stability: bool = False,
) -> PeakCurve:
    """Optimization / performance curves: the peak traced by natural continuation
    in ``parameter`` (Firrone & Zucca Fig. 6).

    The first value gets a full arclength FRF over ``window`` (the global peak
    there). Each next one predicts the peak frequency from the last two and finds
    the maximum of max|x(t)| by :func:`refine_peak` in a bracket around the
    prediction, each trial a Newton solve warm-started from the nearest solution;
    a maximum on the bracket's edge widens it (twice), and failing that the value
    falls back to a full FRF. Far fewer solves than one FRF per value. It follows
    one peak: where the FRF has several maxima of similar height (e.g. a stuck
    and a slipping resonance) it may stay on a lower one; use full sweeps there.
    ``vibration``: the peak of max|x(t) - x0| (the static part left out); ``stability``:
    Hill's stability of each peak's solution (:func:`stability_at`)."""
    lo, hi = window
    if not (0 < lo < hi):
        raise ValueError(f"peak_curve: 'window' = {window} must satisfy 0 < low < high (rad/s)")
    base = base or OperatingPoint(lo)
    vals = np.asarray(values, dtype=float)
    peaks = _Peaks(model, dof, window, settings, vibration)
    omega, amp, how = [], [], []
    stable: list[Stability | None] = []
    for i, v in enumerate(vals):
        point = base.set(parameter, v)
        found = peaks.tracked(point, vals[: i + 1], omega) if i >= 1 and np.isfinite(
            omega[-1]) else None
        if found is None:
            w, a = peaks.swept(point)
            how.append("swept")
        else:
            w, a = found
            how.append("tracked")
        omega.append(w)
        amp.append(a)
        if stability:
            stable.append(stability_at(model, point.set("frequency", w), peaks.memo, settings)
                          if np.isfinite(w) else None)
        if progress:
            progress(i, float(v), w, a, how[-1])
    return PeakCurve(vals, np.array(omega), np.array(amp), how, peaks.solves,
                     stable if stability else None)


class _Peaks:
    """The solves of a peak curve: a full sweep of the window, or the peak tracked near
    its prediction by Brent's method, each trial warm-started from the nearest solution
    kept (``memo``: (w, x) pairs); ``solves``: Newton solves in all."""

    def __init__(self, model: HarmonicBalance, dof, window: tuple[float, float],
                 settings: cont.Settings, vibration: bool) -> None:
        self.model, self.dof, self.window = model, dof, window
        self.settings, self.vibration = settings, vibration
        self.memo: list[tuple[float, np.ndarray]] = []
        self.solves = 0

    def swept(self, point: OperatingPoint) -> tuple[float, float]:
        """(w, peak) of a full FRF over the window (NaN, NaN where it has no point)."""
        lo, hi = self.window
        r = sweep(self.model, "frequency", lo, hi, point.set("frequency", lo),
                  settings=self.settings)
        self.solves += r.branch.steps
        if not len(r):
            return np.nan, np.nan
        w, a = r.peak(self.dof, vibration=self.vibration)
        self.memo.clear()
        self.memo.extend((float(r.omega[i]), r.branch.x[i]) for i in range(len(r)))
        return w, a

    def amplitude_at(self, point: OperatingPoint, w: float) -> float:
        """The response measure at frequency w (0 where Newton fails)."""
        x0 = min(self.memo, key=lambda m: abs(m[0] - w))[1] if self.memo else None
        r = solve_point(self.model, point.set("frequency", w), settings=self.settings, x0=x0,
                        explain=False)
        self.solves += 1
        if not r.converged:
            return 0.0  # no amplitude is smaller: Brent's method moves away
        self.memo.append((w, r.x))
        Q = self.model.recover(r.x, point.set("frequency", w))
        return float(response_measure(self.model.harmonics, output(Q, dof_rows(self.dof))[0],
                                      measure_of(self.vibration)))

    def tracked(self, point: OperatingPoint, vals: np.ndarray, omega: list[float]
                ) -> tuple[float, float] | None:
        """(w, peak) found near the frequency predicted from the last two peaks (``vals``:
        the parameter values up to this one), the bracket widened twice where the maximum
        sits on its edge; None where it is not found so."""
        lo, hi = self.window
        i, v = len(vals) - 1, vals[-1]
        w_pred = omega[-1] if i == 1 else omega[-1] + (omega[-1] - omega[-2]) * (
            (v - vals[i - 1]) / (vals[i - 1] - vals[i - 2]))
        delta = max(2 * abs(omega[-1] - omega[-2]) if i >= 2 else 0.0, 0.01 * (hi - lo))
        for _ in range(3):
            a_, b_ = max(lo, w_pred - delta), min(hi, w_pred + delta)
            w, top = refine_peak(lambda w, point=point: self.amplitude_at(point, w), a_, b_,
                                 1e-7 * (hi - lo))
            edge = min(w - a_, b_ - w) < 1e-4 * (b_ - a_)
            at_window = (w - lo < 1e-4 * (hi - lo)) or (hi - w < 1e-4 * (hi - lo))
            if top > 0 and (not edge or at_window):
                return w, top
            delta *= 3
        return None


def stability_at(model: HarmonicBalance, point: OperatingPoint,
                 near: Sequence[tuple[float, np.ndarray]],
                 settings: cont.Settings = cont.DEFAULT) -> Stability | None:
    """Hill's stability of the solution at ``point`` found by Newton from the nearest in
    frequency of ``near`` ((w, x) pairs); None where there is none or Newton fails."""
    if not near or model.n_unknowns == 0:
        return None
    if undefined(model):
        return None
    x0 = min(near, key=lambda m: abs(m[0] - point.omega))[1]
    r = solve_point(model, point, settings=settings, x0=x0, explain=False)
    return hill_stability(model, r.x, point) if r.converged else None
