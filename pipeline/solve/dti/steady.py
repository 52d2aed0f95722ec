"""Steady states by period-by-period integration, the energy balance, frequency responses
and the step-size convergence table."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .march import Trajectory, check_loads, load_steps, march_loads, state_fields
from .time_model import LoadSteps, State, TimeModel, checked_count, checked_positive, initial_state


# ============================================================= steady state
@dataclass(frozen=True)
class EnergyBalance:
    """Energies over one period, J (see the module docstring).

    external: work of the external load; viscous: dissipated by C;
    friction: (P_all,) dissipated per contact point (``sum T_avg . Dw``);
    normal: (P_all,) work of the normal forces (elastic: ~0 over a period);
    stored: change of the kinetic, elastic and contact-spring energies over the
    period (~0 in a steady state)."""

    external: float
    viscous: float
    friction: np.ndarray
    normal: np.ndarray
    stored: float

    @property
    def residual(self) -> float:
        """external - (viscous + friction + normal + stored): zero up to the
        Newton tolerance (an identity of the trapezoidal rule)."""
        return float(self.external - self.viscous - self.friction.sum() - self.normal.sum()
                     - self.stored)


@dataclass(frozen=True)
class SteadyState:
    """The last, steady period of an integration at one frequency.

    omega: rad/s; steps_per_period; periods: periods integrated in total;
    converged: the period-start state repeated within tol; change: the last
    relative change; trajectory: the last period (steps_per_period + 1
    instants, t from 0); amplitude: (n_dof,) max |q_i(t)| over the period, m
    (cubic Hermite between steps); energy: :class:`EnergyBalance`;
    N0, T0: per contact, the mean normal (P,) and tangential (P, d) forces, N.
    """

    omega: float
    steps_per_period: int
    periods: int
    converged: bool
    change: float
    trajectory: Trajectory
    amplitude: np.ndarray
    energy: EnergyBalance
    N0: tuple[np.ndarray, ...]
    T0: tuple[np.ndarray, ...]

    @property
    def state(self) -> State:
        """State at the end of the last period (phase 0): warm start."""
        return self.trajectory.end

    def coefficients(self, H: int) -> np.ndarray:
        """(n_dof, 2H + 1) harmonic coefficients of q over the last period,
        layout ``[a0, a1, b1, ..., aH, bH]`` (m), by the rectangle rule on the
        steps (exact for orders < steps_per_period / 2 on band-limited data)."""
        return harmonic_coefficients(self.trajectory.q[:-1], checked_count("H", H, 0))


def harmonic_coefficients(x: np.ndarray, H: int) -> np.ndarray:
    """Fourier coefficients of samples x (ns, ...) at phases 2 pi k / ns over
    one period -> (..., 2H + 1) in the layout [a0, a1, b1, ..., aH, bH]."""
    ns = x.shape[0]
    if ns <= 2 * H:
        raise ValueError(f"dti: 'H' = {H} needs more than {2 * H} samples, got {ns}")
    theta = 2 * np.pi * np.arange(ns) / ns
    basis = [np.full(ns, 1.0 / ns)]
    for n in range(1, H + 1):
        basis += [2.0 / ns * np.cos(n * theta), 2.0 / ns * np.sin(n * theta)]
    return np.moveaxis(np.tensordot(np.array(basis), x, axes=(1, 0)), 0, -1)


def hermite_peak(q: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """max_t |q(t)| per column of samples q, v (n + 1, n_dof) at a fixed step
    dt, with q(t) the cubic Hermite interpolant between steps (its extrema
    found in closed form): no sampling error beyond that of q and v."""
    q0, q1, v0, v1 = q[:-1], q[1:], dt * v[:-1], dt * v[1:]
    c1 = v0
    c2 = 3 * (q1 - q0) - 2 * v0 - v1
    c3 = 2 * (q0 - q1) + v0 + v1
    peak = np.max(np.abs(q), axis=0)
    # p'(s) = c1 + 2 c2 s + 3 c3 s^2 = 0 on 0 < s < 1
    A, Bq, Cq = 3 * c3, 2 * c2, c1
    disc = Bq * Bq - 4 * A * Cq
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        lin = np.abs(A) <= 1e-14 * (np.abs(Bq) + np.abs(Cq) + 1e-300)
        roots = [
            np.where(lin, -Cq / Bq, (-Bq + sq) / (2 * A)),
            np.where(lin, np.nan, (-Bq - sq) / (2 * A)),
        ]
        for s in roots:
            ok = np.isfinite(s) & (s > 0) & (s < 1)
            val = np.abs(q0 + c1 * s + c2 * s**2 + c3 * s**3)
            peak = np.maximum(peak, np.max(np.where(ok, val, 0.0), axis=0))
    return peak


def energy_balance(model: TimeModel, tr: Trajectory) -> EnergyBalance:
    """Energies of a trajectory from its start to its end (module docstring), J."""
    spring = 0.0
    for (el, _), h in zip(model.contacts, tr.contacts):
        e = np.sum(h.T**2 / (2 * el.kt), axis=(1, 2))
        spring += float(e[-1] - e[0])

    def mech(k):
        return 0.5 * (tr.v[k] @ model.M @ tr.v[k] + tr.q[k] @ model.K @ tr.q[k])

    stored = mech(-1) - mech(0) + spring
    external, viscous = tr.work[-1] - tr.work[0]
    return EnergyBalance(float(external), float(viscous), tr.friction[-1] - tr.friction[0],
                         tr.normal[-1] - tr.normal[0], float(stored))


def _period_change(model: TimeModel, tr: Trajectory, omega: float) -> float:
    """Relative change of the state over the period: kinematics against the
    largest |q| of the period, contact forces against the largest force."""
    qs = max(np.max(np.abs(tr.q)), 1e-300)
    dk = max(np.max(np.abs(tr.q[-1] - tr.q[0])), np.max(np.abs(tr.v[-1] - tr.v[0])) / omega)
    change = dk / qs
    if tr.contacts:
        fs = max(max(np.max(np.abs(h.T)) for h in tr.contacts),
                 max(np.max(h.N) for h in tr.contacts), 1e-300)
        df = max(max(np.max(np.abs(h.T[-1] - h.T[0])) for h in tr.contacts),
                 max(np.max(np.abs(h.N[-1] - h.N[0])) for h in tr.contacts))
        change = max(change, df / fs)
    return float(change)


def steady_state(model: TimeModel, loads: LoadSteps, omega: float, *,
                 steps_per_period: int = 256, tol: float = 1e-8, max_periods: int = 3000,
                 initial: State | None = None) -> SteadyState:
    """Integrate period by period until the state at the period start repeats.

    Without ``initial`` the load steps of :func:`load_steps` run first; with it
    (a state at phase 0, e.g. the previous frequency's steady state) the full
    load acts at once. Converged when the relative change over a period,
    inflated by the observed contraction r per period (change r / (1 - r), the
    distance to the limit of a geometric sequence), is below ``tol``.
    """
    check_loads(model, loads)
    omega = checked_positive("omega", omega)
    ns = checked_count("steps_per_period", steps_per_period, 8)
    tol = checked_positive("tol", tol)
    max_periods = checked_count("max_periods", max_periods, 1)
    if initial is None:
        step1, step2 = load_steps(model, loads, omega, steps_per_period=ns)
        last = step2 or step1
        state = last.end if last is not None else initial_state(model)
        periods = loads.ramp_periods
    else:
        state, periods = initial, 0
    dt = 2 * np.pi / omega / ns
    tau = dt * np.arange(ns + 1)
    F = loads.static + loads.dynamic(omega, tau)
    prev = None
    converged = False
    change = np.inf
    for _ in range(max_periods):
        tr = march_loads(model, State(0.0, *state_fields(state)), F, dt)
        state = tr.end
        periods += 1
        change = _period_change(model, tr, omega)
        r = min(change / prev, 0.999) if prev else 0.999
        prev = change
        if change * max(1.0, r / (1.0 - r)) <= tol:
            converged = True
            break
    amp = hermite_peak(tr.q, tr.v, dt)
    N0 = tuple(h.N[:-1].mean(axis=0) for h in tr.contacts)
    T0 = tuple(h.T[:-1].mean(axis=0) for h in tr.contacts)
    return SteadyState(omega, ns, periods, converged, change, tr, amp,
                       energy_balance(model, tr), N0, T0)


# ======================================================= frequency response
@dataclass(frozen=True)
class FrequencyResponse:
    """Steady responses over frequencies.

    omega: (n_w,) rad/s; amplitude: (n_w, n_dof) max |q_i(t)|, m;
    coefficients: (n_w, n_dof, 2H + 1) harmonics of q, m; periods: (n_w,)
    periods integrated; converged: (n_w,) bool; N0: per contact (n_w, P) mean
    normal forces, N; T0: per contact (n_w, P, d) mean tangential forces, N;
    dissipation: (n_w, P_all) friction energy per period, J; seconds: (n_w,)
    wall time per frequency, s; end: the last steady state (phase 0), to
    continue the sweep."""

    omega: np.ndarray
    amplitude: np.ndarray
    coefficients: np.ndarray
    periods: np.ndarray
    converged: np.ndarray
    N0: tuple[np.ndarray, ...]
    T0: tuple[np.ndarray, ...]
    dissipation: np.ndarray
    seconds: np.ndarray
    end: State


def frequency_response(model: TimeModel, loads: LoadSteps, omegas: Sequence[float], *,
                       steps_per_period: int = 256, tol: float = 1e-8,
                       max_periods: int = 3000, harmonics: int = 3,
                       progress: Callable[[int, int, float, SteadyState], None] | None = None,
                       initial: State | None = None) -> FrequencyResponse:
    """Steady response at each frequency, in the given order, each one started
    from the previous steady state (the first from the load steps, or from
    ``initial``). ``progress(i, n, omega, steady)`` is called after each."""
    om = np.asarray(omegas, dtype=float).ravel()
    if om.size == 0 or not np.all(np.isfinite(om)) or np.any(om <= 0):
        raise ValueError(f"dti: 'omegas' must be a non-empty list of finite values > 0, "
                         f"got {np.asarray(omegas).tolist()}")
    H = checked_count("harmonics", harmonics, 0)
    if 2 * H >= steps_per_period:
        raise ValueError(f"dti: 'harmonics' = {H} needs steps_per_period > {2 * H}")
    out: list[SteadyState] = []
    secs = []
    state = initial
    for i, w in enumerate(om):
        t0 = time.perf_counter()
        s = steady_state(model, loads, w, steps_per_period=steps_per_period, tol=tol,
                         max_periods=max_periods, initial=state)
        secs.append(time.perf_counter() - t0)
        state = s.state
        out.append(s)
        if progress is not None:
            progress(i, om.size, float(w), s)
    nc = len(model.contacts)
    return FrequencyResponse(
        om,
        np.array([s.amplitude for s in out]),
        np.array([s.coefficients(H) for s in out]),
        np.array([s.periods for s in out]),
        np.array([s.converged for s in out]),
        tuple(np.array([s.N0[c] for s in out]) for c in range(nc)),
        tuple(np.array([s.T0[c] for s in out]) for c in range(nc)),
        np.array([s.energy.friction for s in out]),
        np.array(secs),
        state,
    )


# ================================================== step-size convergence
@dataclass(frozen=True)
class StepConvergence:
    """Steady peak of one DOF against the step: steps_per_period (k,),
    peak (k,) m, difference (k - 1,) between successive refinements, m,
    order (k - 2,) observed order log2(d_i / d_i+1) (for halved steps),
    extrapolated: Richardson estimate from the two finest at the observed
    (or, if undefined, second) order, m; finest: the steady state at the
    finest step."""

    steps_per_period: np.ndarray
    peak: np.ndarray
    difference: np.ndarray
    order: np.ndarray
    extrapolated: float
    finest: SteadyState

    def table(self) -> str:
        """The convergence table as text."""
        lines = ["steps/period   peak max|q|          diff        order"]
        for i, (n, p) in enumerate(zip(self.steps_per_period, self.peak)):
            d = f"{self.difference[i - 1]:11.3e}" if i else " " * 11
            o = f"{self.order[i - 2]:8.3f}" if i >= 2 else ""
            lines.append(f"{n:12d}   {p:.12g}  {d}  {o}")
        lines.append(f"Richardson extrapolation: {self.extrapolated:.12g}")
        return "\n".join(lines)


def step_convergence(model: TimeModel, loads: LoadSteps, omega: float, *, dof: int = 0,
                     steps_per_period: Sequence[int] = (128, 256, 512), tol: float = 1e-10,
                     max_periods: int = 3000, initial: State | None = None
                     ) -> StepConvergence:
    """The steady peak max|q_dof| at successively halved steps. Each refinement
    starts from the previous steady state (the first from the load steps or
    ``initial``); ``tol`` tight so the periodicity error stays below the step
    error."""
    ns = [checked_count("steps_per_period", n, 8) for n in steps_per_period]
    if len(ns) < 2 or any(b != 2 * a for a, b in zip(ns[:-1], ns[1:])):
        raise ValueError(f"dti: 'steps_per_period' = {list(steps_per_period)} must be at "
                         "least two values, each twice the previous")
    if int(dof) != dof or not 0 <= dof < model.n_dof:
        raise ValueError(f"dti: 'dof' = {dof!r} must be an integer in [0, {model.n_dof})")
    peaks = []
    state = initial
    for n in ns:
        s = steady_state(model, loads, omega, steps_per_period=n, tol=tol,
                         max_periods=max_periods, initial=state)
        state = s.state
        peaks.append(s.amplitude[dof])
    peaks = np.array(peaks)
    diff = np.diff(peaks)
    with np.errstate(divide="ignore", invalid="ignore"):
        order = np.log2(np.abs(diff[:-1] / diff[1:]))
    p = order[-1] if order.size and np.isfinite(order[-1]) and order[-1] > 0.5 else 2.0
    extrap = peaks[-1] + diff[-1] / (2.0**p - 1.0)
    return StepConvergence(np.array(ns), peaks, diff, order, float(extrap), s)
