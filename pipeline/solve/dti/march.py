"""Marching the time model: trajectories with contact histories, the two load steps."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .kernel import march
from .time_model import LoadSteps, State, TimeModel, checked_count, checked_positive, initial_state


# =============================================================== histories
@dataclass(frozen=True)
class ContactHistory:
    """Time history of one contact's P points over n + 1 instants.

    T: (n + 1, P, d) tangential forces, N; N: (n + 1, P) normal forces, N;
    u: (n + 1, P, d), v: (n + 1, P) relative displacements, m (v = 0 for the
    constant-load laws); state: (n + 1, P) int8 STICK/SLIP/OPEN codes
    (:data:`microslip.laws.states.SAMPLE_STICK` ...)."""

    T: np.ndarray
    N: np.ndarray
    u: np.ndarray
    v: np.ndarray
    state: np.ndarray


@dataclass(frozen=True)
class Trajectory:
    """A marched time history over n + 1 instants.

    t (n + 1,) s; q, v (n + 1, n_dof) m, m/s; F (n + 1, n_dof) external load, N;
    contacts: one history per contact; work: (n + 1, 2) cumulative work of the
    external load and viscous dissipation since the start, J; friction,
    normal: (n + 1, P_all) cumulative friction dissipation and normal work per
    contact point, J (summed over every sub-step); iterations: Newton
    iterations; events: steps split at a contact transition; end: the state to
    continue from."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    F: np.ndarray
    contacts: tuple[ContactHistory, ...]
    work: np.ndarray
    friction: np.ndarray
    normal: np.ndarray
    iterations: int
    events: int
    end: State


def state_fields(s: State) -> tuple:
    return s.q, s.v, s.T, s.N, s.N_raw, s.g, s.flag


def _acceleration(model: TimeModel, s: State, F0: np.ndarray) -> np.ndarray:
    """a = M^-1 (F - C v - K q - B^T f) at a state, m/s^2."""
    pk = model.packed
    f = np.zeros(pk.B.shape[0])
    for p in range(pk.n0.size):
        r, d = pk.row0[p], pk.dim[p]
        f[r: r + d] = s.T[p, :d]
        if pk.normal[p]:
            f[r + d] = s.N[p]
    rhs = F0 - model.C @ s.v - model.K @ s.q - pk.B.T @ f
    return np.linalg.solve(model.M, rhs)


def march_loads(model: TimeModel, start: State, F: np.ndarray, dt: float, *,
                 rtol: float = 1e-10, max_iter: int = 40, max_events: int = 8,
                 min_fraction: float = 1e-9) -> Trajectory:
    """March len(F) - 1 steps of dt from start; F[0] is the load at start.t."""
    pk = model.packed
    n, P = model.n_dof, model.n_points
    steps = F.shape[0] - 1
    q, v = start.q.copy(), start.v.copy()
    a = _acceleration(model, start, F[0])
    Tc, Nc, Nrc, gc = start.T.copy(), start.N.copy(), start.N_raw.copy(), start.g.copy()
    sc = start.flag.astype(np.int8).copy()
    q_out, v_out = np.empty((steps + 1, n)), np.empty((steps + 1, n))
    T_out, N_out = np.empty((steps + 1, P, 2)), np.empty((steps + 1, P))
    s_out, g_out = np.empty((steps + 1, P), np.int8), np.empty((steps + 1, P, 3))
    e_out, wf_out, wn_out = np.empty((steps + 1, 2)), np.empty((steps + 1, P)), np.empty(
        (steps + 1, P))
    total, events, failed = march(
        (q, v, a, Tc, Nc, Nrc, gc, sc), (model.M, model.C, model.K),
        (pk.B, pk.row0, pk.dim, pk.normal, pk.kt, pk.kn, pk.mu, pk.n0),
        np.ascontiguousarray(F, dtype=float), float(dt), (float(rtol), int(max_iter)),
        (int(max_events), float(min_fraction)),
        (q_out, v_out, T_out, N_out, s_out, g_out, e_out, wf_out, wn_out))
    t = start.t + dt * np.arange(steps + 1)
    if failed >= 0:
        raise RuntimeError(f"dti: Newton did not converge in {max_iter} iterations at "
                           f"t = {t[failed]:.6g} s (step {failed}); reduce the time step")
    histories = []
    for i, (el, _) in enumerate(model.contacts):
        sl = slice(pk.offsets[i], pk.offsets[i + 1])
        d = el.dim
        histories.append(ContactHistory(
            T_out[:, sl, :d], N_out[:, sl], g_out[:, sl, :d],
            g_out[:, sl, 2] if el.variable_normal else np.zeros_like(N_out[:, sl]),
            s_out[:, sl],
        ))
    end = State(float(t[-1]), q, v, Tc, Nc, Nrc, gc, sc)
    return Trajectory(t, q_out, v_out, F, tuple(histories), e_out, wf_out, wn_out, int(total),
                      int(events), end)


def integrate(model: TimeModel, force: Callable[[float], np.ndarray] | np.ndarray,
              t_end: float, dt: float, *, initial: State | None = None) -> Trajectory:
    """March the model from ``initial`` (default: at rest, t = 0) to ``t_end``.

    force: a callable ``F(t) -> (n_dof,)`` in N, or the samples (n_steps + 1,
    n_dof) at the step ends; t_end, dt in s (the last step is shortened to
    land on t_end if dt does not divide the span)."""
    start = initial_state(model) if initial is None else initial
    dt = checked_positive("dt", dt)
    t_end = float(t_end)
    if not np.isfinite(t_end) or t_end <= start.t:
        raise ValueError(f"dti: 't_end' = {t_end!r} must be finite and after the start "
                         f"t = {start.t:g} s")
    steps = max(1, int(np.ceil((t_end - start.t) / dt - 1e-9)))
    dt = (t_end - start.t) / steps
    t = start.t + dt * np.arange(steps + 1)
    if callable(force):
        F = np.array([np.asarray(force(float(ti)), dtype=float) for ti in t])
    else:
        F = np.asarray(force, dtype=float)
    if F.shape != (steps + 1, model.n_dof):
        raise ValueError(f"dti: 'force' gives shape {F.shape}, expected (n_steps + 1, n_dof) "
                         f"= {(steps + 1, model.n_dof)}")
    if not np.all(np.isfinite(F)):
        raise ValueError("dti: 'force' contains NaN or Inf")
    return march_loads(model, start, F, dt)


# =============================================================== load steps
def check_loads(model: TimeModel, loads: LoadSteps) -> None:
    if not isinstance(loads, LoadSteps):
        raise ValueError(f"dti: 'loads' must be LoadSteps, got {type(loads).__name__}")
    if loads.static.shape != (model.n_dof,):
        raise ValueError(f"dti: 'loads' are for {loads.static.size} DOFs, the model has "
                         f"{model.n_dof}")


def load_steps(model: TimeModel, loads: LoadSteps, omega: float, *,
               steps_per_period: int = 256, initial: State | None = None
               ) -> tuple[Trajectory | None, Trajectory | None]:
    """The two load steps of Fig. 13: (step 1, step 2) trajectories.

    Step 1 (ramp_time + settle_time, dynamic load off) ramps the static load
    quasi-statically from ``initial`` (default at rest); step 2 (ramp_periods
    periods of 2 pi / omega) ramps the harmonic amplitude linearly, static load
    held. A step of zero length is None. dt = 2 pi / (omega steps_per_period)
    in both steps (step 1 shortened to end on its duration)."""
    check_loads(model, loads)
    omega = checked_positive("omega", omega)
    ns = checked_count("steps_per_period", steps_per_period, 8)
    dt = 2 * np.pi / omega / ns
    state = initial_state(model) if initial is None else initial
    step1 = step2 = None
    t1 = loads.ramp_time + loads.settle_time
    if t1 > 0:
        n1 = max(1, int(np.ceil(t1 / dt)))
        t = np.linspace(0.0, t1, n1 + 1)
        ramp = np.ones_like(t)
        if loads.ramp_time > 0:
            rising = t < loads.ramp_time
            ramp[rising] = 0.5 * (1 - np.cos(np.pi * t[rising] / loads.ramp_time))
        F = ramp[:, None] * loads.static
        step1 = march_loads(model, state, F, t1 / n1)
        state = step1.end
    if loads.ramp_periods > 0:
        n2 = ns * loads.ramp_periods
        tau = dt * np.arange(n2 + 1)
        F = loads.static + (tau / tau[-1])[:, None] * loads.dynamic(omega, tau)
        step2 = march_loads(model, State(0.0, *state_fields(state)), F, dt)
    return step1, step2
