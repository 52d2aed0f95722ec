"""Forced response: sweeps of a harmonic-balance model and what a user reads off them.

:func:`sweep` follows the solution in one scalar parameter (frequency, excitation
level, mass multiplier, preload) by natural or arclength continuation and wraps
the branch in a :class:`Response`, which recovers every DOF, peaks ``max|x(t)|``,
contact states and dissipated energies point by point.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from microslip.fourier import Harmonics
from microslip.laws.coulomb import ContactResponse

from . import continuation as cont
from .hbm import HarmonicBalance
from .jacobian import BalanceJacobian
from .linear import PARAMETERS, OperatingPoint

METHODS = ("arclength", "natural")
LINEAR_SAMPLES = 801  # parameter samples of a sweep with no contact DOF
#: A harmonic resonates when its normalised modal dynamic stiffness
#: |w_i^2 - (n w)^2 + i n w c_i| / max(w_i^2, (n w)^2) falls below this: n w within 0.05 %
#: of w_i with a modal damping ratio below 5e-4 (at resonance the measure is 2 zeta), an
#: amplification over 1000 that only the contacts can bound.
RESONANCE_TOL = 1e-3
#: The fraction of the excitation a cold-start ramp begins at: the contact forces scale with
#: the excitation and the slip limits do not, so the stuck linear guess is the solution there
#: unless the full load exceeds the slip limits 1000-fold.
RAMP_START = 1e-3


@dataclass
class Response:
    """A solved branch of a harmonic-balance model."""

    model: HarmonicBalance
    branch: cont.Branch
    base: OperatingPoint

    def __len__(self) -> int:
        return len(self.branch)

    @property
    def parameter(self) -> str:
        return self.branch.parameter

    @property
    def values(self) -> np.ndarray:
        return self.branch.values

    def point(self, i: int) -> OperatingPoint:
        return self.base.set(self.parameter, self.branch.values[i])

    @property
    def omega(self) -> np.ndarray:
        """(n_points,) excitation frequency, rad/s."""
        return np.array([self.point(i).omega for i in range(len(self))])

    def coefficients(self, dofs: Sequence[int] | np.ndarray | None = None) -> np.ndarray:
        """(n_points, n_outputs, n_coeffs) harmonic coefficients (m) of DOFs (indices) or of
        outputs given as rows (n_outputs, n_dof) of the shared DOFs."""
        return np.array([output(self.model.recover(x, self.point(i)), dofs)
                         for i, x in enumerate(self.branch.x)])

    def amplitude(self, dofs: Sequence[int] | np.ndarray | None = None,
                  oversample: int = 4, vibration: bool = False) -> np.ndarray:
        """(n_points, n_outputs) max_t |x(t)| of DOFs or output rows, m (``vibration``:
        max_t |x(t) - x0|, the static part left out)."""
        return response_measure(self.model.harmonics, self.coefficients(dofs),
                                measure_of(vibration), oversample)

    def top(self, dof: int | np.ndarray, *, vibration: bool = False
            ) -> tuple[int, np.ndarray]:
        """(the point of the largest response of one DOF or output row, the (n_points,)
        responses: max|x(t)|, or max|x(t) - x0| with ``vibration``)."""
        amp = self.amplitude(dof_rows(dof), vibration=vibration)[:, 0]
        return int(np.argmax(amp)), amp

    def peak(self, dof: int | np.ndarray, *, xtol: float = 1e-9,
             vibration: bool = False) -> tuple[float, float]:
        """(parameter value, max|x(t)|) at the largest response of one DOF (``vibration``:
        of max|x(t) - x0|).

        The sampled maximum is refined between its neighbours (:func:`refine_peak`),
        solving the balance afresh at each trial value (its start between the solutions
        either side, :func:`between`); ``xtol`` is relative to that bracket. Where the
        maximum sits on a fold (the branch turns back around it) or next to a jump of a
        natural sweep the sampled maximum is returned unrefined."""
        i, amp = self.top(dof, vibration=vibration)
        lam = self.values
        jumps = {k for jump in self.branch.jumps for k in jump}  # no bracket across a jump
        if i == 0 or i == len(self) - 1 or (lam[i] - lam[i - 1]) * (lam[i + 1] - lam[i]) <= 0 \
                or i in jumps:
            return float(lam[i]), float(amp[i])
        h = self.model.harmonics
        settings = cont.Settings(tol=1e-11)
        tried = {float(lam[j]): self.branch.x[j] for j in (i - 1, i, i + 1)}

        def amplitude_at(value: float) -> float:
            r = solve_point(self.model, self.base.set(self.parameter, value),
                            settings=settings, x0=between(tried, value), explain=False)
            if not r.converged:
                return 0.0
            tried[value] = r.x
            Q = self.model.recover(r.x, self.base.set(self.parameter, value))
            return float(response_measure(h, output(Q, dof_rows(dof))[0], measure_of(vibration)))

        a, b = sorted((lam[i - 1], lam[i + 1]))
        value, top = refine_peak(amplitude_at, a, b, xtol * (b - a))
        return (float(value), top) if top > amp[i] else (float(lam[i]), float(amp[i]))

    def solutions_at(self, value: float, settings: cont.Settings = cont.DEFAULT
                     ) -> list[np.ndarray]:
        """(n_unknowns,) every solution of the branch at parameter ``value``: one per pair
        of consecutive points that brackets it (a fold gives several; a natural sweep's
        jump is no part of the branch), by :func:`continuation.solutions_at`."""
        xs, fs = scales(self.model, self.base.set(self.parameter, value))
        return [r.x for r in cont.solutions_at(
            problem(self.model, self.base, self.parameter), self.values, self.branch.x, value,
            x_scale=xs, f_scale=fs, settings=settings, jumps=[i for i, _ in self.branch.jumps])]

    def sampling_shift(self, i: int) -> tuple[np.ndarray, float]:
        """(dx, d parameter): the first-order shift of point ``i`` normal to the branch
        when the period is sampled twice as finely (:func:`sampling_shift`); the normal in
        the continuation's metric (unknowns by their rms over the branch, the parameter by
        its range), the tangent the secant through the neighbouring points of its branch."""
        x, lam = self.branch.x, self.values
        lo, hi = max(i - 1, 0), min(i + 1, len(self) - 1)
        jumps = {tuple(j) for j in self.branch.jumps}  # no secant across a jump
        lo, hi = (i if (lo, i) in jumps else lo), (i if (i, hi) in jumps else hi)
        sx = float(np.sqrt(np.mean(x**2))) or 1.0
        sl = float(np.ptp(lam)) or 1.0
        if hi == lo:  # a single point: the parameter held
            border = np.append(np.zeros(x.shape[1]), 1.0)
        else:
            # the continuation's metric: unknowns by their rms (hence the count), parameter
            # by its range
            border = np.append((x[hi] - x[lo]) / (x.shape[1] * sx**2),
                               (lam[hi] - lam[lo]) / sl**2)
        return sampling_shift(self.model, x[i], self.point(i), self.parameter, border)

    def contacts(self, i: int, histories: bool = False) -> list[ContactResponse]:
        """Contact forces, states and dissipation at point ``i``, per contact."""
        return self.model.contact_response(self.branch.x[i], self.point(i), histories)

    def energy(self, i: int) -> dict[str, float]:
        """Work per cycle at point ``i`` (see HarmonicBalance.energy_balance)."""
        return self.model.energy_balance(self.branch.x[i], self.point(i))


#: The response measures of an output: ``peak`` max_t |x(t)|, ``vibration``
#: max_t |x(t) - x0| (the static part, order 0, left out) and ``harmonic`` |X_n| of the
#: lowest dynamic order n.
MEASURES = ("peak", "vibration", "harmonic")


def response_measure(h: Harmonics, coefficients: np.ndarray, measure: str = "peak",
                     oversample: int = 4) -> np.ndarray:
    """(...) one of :data:`MEASURES` of coefficient rows (..., n_coeffs), m; the maxima
    over time from ``oversample`` x the period's samples, refined (``Harmonics.peak``)."""
    c = np.array(coefficients, dtype=float)
    if measure == "harmonic":
        k = h.dynamic_orders.index(min(h.dynamic_orders))
        return np.hypot(c[..., h.cos_index[k]], c[..., h.sin_index[k]])
    if measure == "vibration" and h.has_static:
        c[..., 0] = 0.0
    return h.peak(c, oversample)


def measure_of(vibration: bool) -> str:
    """The response measure of a peak: max|x(t) - x0| with ``vibration``, else max|x(t)|."""
    return "vibration" if vibration else "peak"


def refine_peak(response: Callable[[float], float], low: float, high: float, xatol: float
                ) -> tuple[float, float]:
    """(x, response(x)) at the largest response between ``low`` and ``high``: Brent's
    bounded method (parabolic steps where the response is smooth, golden-section ones
    where a stick/slip kink sits at the top) to ``xatol`` (absolute). ``response`` returns
    0 where a trial fails (no response is smaller, so the search moves away; finite, as
    the parabolas need). Every peak refinement of the project is this one."""
    from scipy.optimize import minimize_scalar

    best = [-np.inf, low]

    def minus(x: float) -> float:
        value = response(x)
        if value > best[0]:
            best[:] = [value, x]
        return -value

    minimize_scalar(minus, bounds=(low, high), method="bounded", options={"xatol": xatol})
    return float(best[1]), float(best[0])


def between(tried: dict[float, np.ndarray], v: float, interpolate: bool = True
            ) -> np.ndarray:
    """A start at parameter ``v`` from the solutions ``tried`` (value -> x): linear between
    the nearest on either side (the branch is smooth between its computed points; at a
    whole disk's peak the nearest alone, a step away, often failed to converge), else (or
    without ``interpolate``: neighbours on two branches) the nearest."""
    below = [t for t in tried if t <= v]
    above = [t for t in tried if t >= v]
    if not (below and above and interpolate):
        return tried[min(tried, key=lambda t: abs(t - v))]
    a, b = max(below), min(above)
    if a == b:
        return tried[a]
    s = (v - a) / (b - a)
    return (1.0 - s) * tried[a] + s * tried[b]


def output(Q: np.ndarray, dofs: Sequence[int] | np.ndarray | None) -> np.ndarray:
    """(n_outputs, n_coeffs) of recovered coefficients Q (n_dof, n_coeffs): DOF indices
    select rows, a 2-D array (n_outputs, n_dof) combines them (an FE output: a node's
    displacement along a direction); None: every DOF."""
    if dofs is None:
        return Q
    sel = np.asarray(dofs)
    return sel @ Q if sel.ndim == 2 else Q[sel]


def dof_rows(dof: int | np.ndarray) -> list[int] | np.ndarray:
    """One output as a selection: a DOF index, or an (n_dof,) row."""
    row = np.asarray(dof)
    return row[None, :] if row.ndim == 1 else [int(dof)]


def problem(model: HarmonicBalance, base: OperatingPoint, parameter: str) -> cont.Problem:
    """The continuation problem of ``model`` in ``parameter``: (x, value, jacobian) ->
    (R, dR/dx, dR/d parameter) at ``base`` with the parameter set to the value."""

    def fun(x: np.ndarray, value: float, jac: bool):
        return model.residual(x, base.set(parameter, value), parameter, jacobian=jac,
                              structured=structured)

    structured = model.structured
    return fun


def scales(model: HarmonicBalance, point: OperatingPoint, x_scale: float | None = None
           ) -> tuple[float, float]:
    """(x_scale, f_scale): displacement and force that make unknowns and
    residuals O(1). The force scale is the largest condensed external force
    (static or dynamic) or, without any, the largest contact force limit; the
    displacement scale is the response of the linear system with stuck contacts, or
    ``x_scale`` where given (positive)."""
    lin = model.condensed(point)
    f = float(np.max(np.abs(lin.F))) if lin.F.size else 0.0
    if f == 0.0:
        f = max(
            (c.elements.force_scale() for c in model.contacts),
            default=0.0,
        )
    f = f if f > 0 else 1.0
    if x_scale is not None and x_scale > 0:
        return float(x_scale), f
    guess = model.linear_guess(point, stuck=True)
    x = float(np.max(np.abs(guess))) if guess.size else 0.0
    return (x if x > 0 else 1.0), f


def initial_guess(model: HarmonicBalance, point: OperatingPoint, f_scale: float) -> np.ndarray:
    """The better (smaller residual) of the free and the stuck linear responses."""
    best, best_res = None, np.inf
    for stuck in (False, True):
        x = model.linear_guess(point, stuck=stuck)
        if not np.all(np.isfinite(x)):
            continue
        R, _, _ = model.residual(x, point, jacobian=False)
        res = float(np.max(np.abs(R))) / f_scale if R.size else 0.0
        if res < best_res:
            best, best_res = x, res
    return best if best is not None else np.zeros(model.n_unknowns)


def sweep(
    model: HarmonicBalance,
    parameter: str,
    start: float,
    stop: float,
    base: OperatingPoint,
    *,
    method: str = "arclength",
    settings: cont.Settings = cont.DEFAULT,
    x0: np.ndarray | None = None,
    x_scale: float | None = None,
    progress: Callable[[int, float, int], None] | None = None,
    retry: bool = True,
    watch: Callable[[float, np.ndarray], str] | None = None,
) -> Response:
    """Follow the solution of ``model`` as ``parameter`` goes from start to stop.

    base: values of the other parameters (and of this one, overridden by the
    sweep). Bad arguments raise ValueError before any solve. retry: where the cold
    start (no ``x0``) fails at the first point, reach it by :func:`excitation_ramp`.
    watch: see :func:`continuation.arclength` (arclength only).
    """
    settings = _sweep_settings(model, parameter, start, stop, method, settings, x0)
    if model.n_unknowns == 0:
        # no contact DOF: the response is linear and recovered exactly at every DOF;
        # sample the parameter (Response.peak refines a resonance between samples)
        values = np.linspace(start, stop, LINEAR_SAMPLES)
        branch = cont.Branch(parameter, values, np.zeros((values.size, 0)),
                             np.zeros(values.size), np.zeros(values.size, dtype=int),
                             message="linear: no contact DOF, sampled")
        return Response(model, branch, base)
    p0 = base.set(parameter, start)
    xs, fs = scales(model, p0)
    if x_scale is not None:
        xs = float(x_scale)
    cold = x0 is None
    if cold:
        x0 = initial_guess(model, p0, fs)

    fun = problem(model, base, parameter)

    def follow(x_start: np.ndarray) -> cont.Branch:
        if method == "arclength":
            return cont.arclength(fun, x_start, start, stop, parameter=parameter,
                                  x_scale=xs, f_scale=fs, settings=settings, progress=progress,
                                  watch=watch)

        def guesses(value):
            p = base.set(parameter, value)
            return [model.linear_guess(p), model.linear_guess(p, stuck=True)]

        return cont.natural(fun, x_start, start, stop, parameter=parameter, x_scale=xs,
                            f_scale=fs, settings=settings, progress=progress, guesses=guesses)

    branch = follow(x0)
    retried = ""  # what the ramp did, for the end of the message
    if (cold and retry and not len(branch) and branch.failed is not None
            and branch.status == "stopped" and not _structural_hint(model, branch.failed[1], p0)):
        try:
            ramp, retried = excitation_ramp(model, p0, settings=settings)
        except KeyboardInterrupt:
            branch.status, branch.message = "interrupted", (
                f"interrupted by the user while ramping the excitation at {parameter} = "
                f"{start:.6g}")
            return Response(model, branch, base)
        if ramp is not None:
            steps = branch.steps
            branch = follow(ramp.x)
            branch.steps += steps
            retried = f"; first point: the cold start failed, {retried}"
    _say_why(model, branch, base, parameter)
    branch.message = (branch.message + retried).removeprefix("; ")
    return Response(model, branch, base)


def _sweep_settings(model: HarmonicBalance, parameter: str, start: float, stop: float,
                    method: str, settings: cont.Settings, x0: np.ndarray | None
                    ) -> cont.Settings:
    """The settings of a sweep whose arguments are checked (ValueError before any solve):
    a frequency or mass sweep never goes through zero."""
    if parameter not in PARAMETERS:
        raise ValueError(f"sweep: 'parameter' = {parameter!r} is not one of {PARAMETERS}")
    if method not in METHODS:
        raise ValueError(f"sweep: 'method' = {method!r} is not one of {METHODS}")
    cont.check_range(start, stop, parameter)
    if parameter == "frequency" and min(start, stop) <= 0:
        raise ValueError(f"sweep: frequency range must be > 0 rad/s, got {start}..{stop}")
    if parameter in ("mass",) and min(start, stop) <= 0:
        raise ValueError(f"sweep: mass multiplier range must be > 0, got {start}..{stop}")
    if x0 is not None and np.shape(x0) != (model.n_unknowns,):
        raise ValueError(f"sweep: 'x0' has shape {np.shape(x0)}, expected ({model.n_unknowns},)")
    if parameter in ("frequency", "mass") and settings.lower < 0:
        settings = dataclasses.replace(settings, lower=0.0)  # never through w = 0 or m = 0
    return settings


def _say_why(model: HarmonicBalance, branch: cont.Branch, base: OperatingPoint,
             parameter: str) -> None:
    """A branch that stopped short gets the hint its failed iterate (else its last
    converged point) gives of the cause."""
    if branch.complete or branch.status == "interrupted":
        return
    tries = [branch.failed] if branch.failed is not None else []
    if len(branch):
        tries.append((branch.values[-1], branch.x[-1]))
    for value, x in tries:
        hint = failure_hint(model, x, base.set(parameter, value))
        if hint:
            branch.message += hint
            break


def failure_hint(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> str:
    """Why a solve may have stalled at x, and what to change: a static problem that nothing
    holds, an undamped resonance of a harmonic, or stick arcs between samples ("" if none
    shows)."""
    finite = np.all(np.isfinite(x))
    return _structural_hint(model, x, point) or (sampling_hint(model, x, point) if finite
                                                 else "")


def _structural_hint(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> str:
    """The causes no other start cures: the linear part itself is singular at the point."""
    static = static_hint(model, x, point) if np.all(np.isfinite(x)) else ""
    return static or resonance_hint(model, point)


def static_hint(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> str:
    """The static (order-0) block of the Jacobian singular: a body (a free damper) that no
    contact holds statically, every point of it slipping or open, and no load closing them.
    Its static position is then undetermined and Newton wanders; say so instead."""
    h = model.harmonics
    if not h.has_static or model.n_unknowns == 0:
        return ""
    _, J, _ = model.residual(x, point, structured=model.structured)
    if isinstance(J, BalanceJacobian):  # order 0's block is J's own (nothing projected)
        J0 = np.ascontiguousarray(J.order_blocks()[0].real)
    else:
        a0 = np.arange(model.dofs.size) * h.n_coeffs  # DOF-major: a0 first
        J0 = J[np.ix_(a0, a0)]
    lu, _, info = sla.lapack.dgetrf(J0)
    rcond = 0.0 if info else sla.lapack.dgecon(lu, np.abs(J0).sum(axis=0).max())[0]
    if rcond >= 1e-12:
        return ""
    states = np.concatenate([r.state for r in model.contact_response(x, point)])
    n_open = int(np.sum(states == 4))
    n_slip = int(np.sum((states == 1) | (states == 2) | (states == 3)))
    loaded = bool(np.any(model.forces(point)[0][model.harmonics.orders.index(0)]))
    remedy = ("the static load does not hold it there (where the branch folds, arclength "
              "continuation follows the turn)" if loaded else
              "a free body needs a static load that closes its contacts (a centrifugal load "
              "with its speed) or an interference")
    return (f"; the static (order-0) problem is singular at w = {point.omega:.6g} rad/s: "
            f"nothing holds a body in place ({n_open} of {states.size} contact points open, "
            f"{n_slip} slipping): {remedy}")


def resonance_hint(model: HarmonicBalance, point: OperatingPoint) -> str:
    """A harmonic order n >= 1 at an undamped resonance of the linear part: n w at a natural
    frequency w_i of K_n, M_n (contacts free, or stuck: their stick stiffness added) with no
    damping to bound it. The order-n block of the Jacobian is then singular, or nearly, in a
    slipping (free) or stuck contact state; no start or sampling cures that.

    Measure per mode (M-normalised modes of order n): the modal dynamic stiffness
    |w_i^2 - (n w)^2 + i n w c_i| over max(w_i^2, (n w)^2), the order's smallest singular
    value in that basis, normalised; flagged below RESONANCE_TOL."""
    lin = model.linear
    best = None  # (measure, order, natural frequency, contact state)
    for o, K, M, C in zip(lin.orders, lin.K, lin.mass(point), lin.C):
        if o == 0:
            continue
        nw2 = (o * point.omega) ** 2
        stuck = K.astype(complex)
        stuck[: lin.n_dof, : lin.n_dof] += model.stick_stiffness(o)
        # only modes with |w_i^2 - (n w)^2| < tol max(w_i^2, (n w)^2) can measure below
        # tol: those alone are found (a whole disk's order block is thousands of DOFs: its
        # every mode took minutes, the hint of a stopped sweep)
        window = (nw2 * (1.0 - RESONANCE_TOL), nw2 / (1.0 - RESONANCE_TOL))
        for state, Ks in (("free", K), ("stuck", stuck)):
            try:
                lam, phi = sla.eigh(Ks, M, subset_by_value=window, driver="gvx")
            except (np.linalg.LinAlgError, ValueError):
                return ""
            if not lam.size:
                continue
            c = np.real(np.sum(phi.conj() * (C @ phi), axis=0))
            measure = np.abs(lam - nw2 + 1j * np.sqrt(nw2) * c) / np.maximum(np.abs(lam), nw2)
            i = int(np.argmin(measure))
            if best is None or measure[i] < best[0]:
                best = (float(measure[i]), o, float(np.sqrt(max(lam[i], 0.0))), state)
    if best is None or not best[0] < RESONANCE_TOL:
        return ""
    measure, o, wn, state = best
    return (f"; harmonic {o} resonates at w = {point.omega:.6g} rad/s: {o} w = "
            f"{o * point.omega:.6g} rad/s is at the natural frequency {wn:.6g} rad/s of the "
            f"linear part (contacts {state}; normalised dynamic stiffness {measure:.1e} < "
            f"{RESONANCE_TOL:g}) and no damping bounds it, so the Jacobian is (nearly) "
            "singular there: add damping or skip this frequency")


def sampling_shift(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint,
                   parameter: str, border: np.ndarray) -> tuple[np.ndarray, float]:
    """First-order shift (dx (n_unknowns,), d parameter) of the branch point (``x``,
    ``point``) when the period is sampled twice as finely, normal to the branch: the
    bordered system [J dR/dp; border^T] [dx; dp] = [-(R_2N(x) - R_N(x)); 0], J at the
    model's N samples, ``border`` (n_unknowns + 1,) the metric-weighted branch tangent
    (regular at a fold, where J alone is singular; [0, ..., 0, 1] holds the parameter).

    The residual difference isolates the sampling's share of the contact forces (R_N(x)
    is zero to the solver's tolerance): a-posteriori, how much a converged point depends
    on the sampling (a lightly damped resonance amplifies a small force error: hence the
    solve, not the residual alone). NaN where the bordered system is singular."""
    R, J, dR = model.residual(x, point, parameter, structured=model.structured)
    fine = model.with_samples(2 * model.harmonics.n_samples)
    b = np.append(-(fine.residual(x, point, jacobian=False)[0] - R), 0.0)
    try:
        if isinstance(J, BalanceJacobian):
            d = J.bordered_solve(dR, border[:-1], border[-1], b)
        else:
            A = np.block([[J, dR[:, None]], [border[None, :]]])
            with warnings.catch_warnings():  # an ill-conditioned system gives a large shift
                warnings.simplefilter("ignore", sla.LinAlgWarning)
                d = sla.solve(A, b, check_finite=False)
    except (np.linalg.LinAlgError, ValueError):
        return np.full_like(x, np.nan), float("nan")
    return d[:-1], float(d[-1])


def undersampled_points(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> int:
    """The contact points whose stick arcs at (x, ``point``) fall within two samples."""
    return sum(int(np.count_nonzero(r.undersampled)) for r in model.contact_response(x, point))


def sampling_hint(model: HarmonicBalance, x: np.ndarray, point: OperatingPoint) -> str:
    """A remedy for a stalled solve when stick arcs fall between samples."""
    n = undersampled_points(model, x, point)
    if n == 0:
        return ""
    return (f"; at {n} contact point(s) a whole stick arc falls between two of the "
            f"{model.harmonics.n_samples} samples per period (contact stiffness high against "
            "the motion): raise n_samples or lower kt")


def solve_point(
    model: HarmonicBalance,
    point: OperatingPoint,
    *,
    settings: cont.Settings = cont.DEFAULT,
    x0: np.ndarray | None = None,
    retry: bool = True,
    explain: bool = True,
    x_scale: float | None = None,
) -> cont.NewtonResult:
    """One harmonic-balance solution at a fixed operating point.

    retry: where the cold start (no ``x0``) fails and the linear part is not singular
    there, reach the point by :func:`excitation_ramp` (its ``reason`` then says so).
    explain: a failure's ``reason`` says why (the hints of :func:`failure_hint`: a whole
    disk's order block searched for its modes near the point, ~10 s); False where the
    caller only asks whether it converged (a peak's trial, which moves on). A cold start
    with ``retry`` still runs the structural check that decides the retry. ``x_scale``:
    the unknowns' scale where the caller knows it (a peak's trials: its neighbours'),
    instead of the stuck linear response's (a dense solve per order: on a whole disk of
    2,304 contact DOFs ~10x the Newton solve it scales)."""
    xs, fs = scales(model, point, x_scale)
    cold = x0 is None
    if cold:
        x0 = initial_guess(model, point, fs)

    def fun(x, lam, jac):
        return model.residual(x, point, None, jacobian=jac, structured=model.structured)

    r = cont.newton(fun, x0, 0.0, x_scale=xs, f_scale=fs, settings=settings)
    if r.converged or not (explain or cold and retry):
        return r
    structural = _structural_hint(model, r.x, point)
    retried = ""
    if cold and retry and not structural:
        ramp, retried = excitation_ramp(model, point, settings=settings)
        if ramp is not None:
            return cont.NewtonResult(ramp.x, True, ramp.iterations, ramp.residual,
                                     f"the cold start failed ({r.reason}); {retried}")
    hint = structural or (sampling_hint(model, r.x, point) if np.all(np.isfinite(r.x))
                          else "")
    return cont.NewtonResult(r.x, False, r.iterations, r.residual, r.reason + hint + retried)


def excitation_ramp(
    model: HarmonicBalance,
    point: OperatingPoint,
    *,
    settings: cont.Settings = cont.DEFAULT,
) -> tuple[cont.NewtonResult | None, str]:
    """The solution at ``point`` reached by continuation in the excitation, from RAMP_START
    of it (every contact stuck: the linear guess is exact) up to the point's value; for
    cold starts that fail where the contacts are stiff and the response sharp.

    Natural continuation first (the response grows monotonically with the load), then
    arclength (it crosses the corners where a contact state changes along the whole orbit).
    Returns (solution or None, what was tried: for the caller's message). (None, "") where
    the point has no dynamic load to ramp. KeyboardInterrupt if the user stops a ramp."""
    full = point.excitation
    forces = model.forces(point)[0]
    if full == 0 or not any(np.any(f) for o, f in zip(model.harmonics.orders, forces) if o):
        return None, ""
    xs, fs = scales(model, point)
    low = RAMP_START * full
    x0 = initial_guess(model, point.set("excitation", low), fs)
    # never through zero load (arclength could turn back there)
    ramp_settings = dataclasses.replace(settings, lower=0.0) if full > 0 else settings

    fun = problem(model, point, "excitation")

    def at_point(x, lam, jac):
        return model.residual(x, point, None, jacobian=jac, structured=model.structured)

    reached = []
    for name, method in (("natural", cont.natural), ("arclength", cont.arclength)):
        b = method(fun, x0, low, full, parameter="excitation", x_scale=xs, f_scale=fs,
                   settings=ramp_settings)
        if b.status == "interrupted":
            raise KeyboardInterrupt
        if b.complete:  # polish at the exact point (the last step may land a rounding short)
            r = cont.newton(at_point, b.x[-1], 0.0, x_scale=xs, f_scale=fs, settings=settings)
            if r.converged:
                return r, (f"reached by {name} continuation in the excitation from "
                           f"{RAMP_START:g} x its value ({len(b)} points)")
            reached.append(f"{name} reached the full value, where Newton then failed "
                           f"({r.reason})")
            continue
        reached.append(f"{name} reached {b.values[-1] / full:.3g} x" if len(b) else
                       f"{name} found no start")
    return None, (f"; retried by continuation in the excitation from {RAMP_START:g} x its "
                  f"value: {', '.join(reached)} (a sweep in frequency from a point that "
                  "converges may reach it)")
