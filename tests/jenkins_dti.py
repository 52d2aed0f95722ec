"""Independent reference: event-driven time integration of the single-DOF
Jenkins oscillator ``m x'' + c x' + k x + T = P cos(w t)``.

Shares no code with the harmonic-balance path: the stick/slip switches are
located exactly as events of SciPy's DOP853 (stick -> slip when
``|kt (x - w)|`` reaches ``mu N``; slip -> stick when the velocity reverses),
so the only errors are the integrator's tolerances.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def steady_peak(m, c, k, kt, fs, P, omega, x0, v0, T0, *, max_periods=400, tol=1e-10):
    """max |x(t)| over one steady period, starting from (x0, v0, T0).

    Integrates period by period until the state after a period repeats to
    ``tol`` (relative to the amplitude); returns (peak, periods used)."""
    period = 2 * np.pi / omega
    stick = abs(T0) < fs
    w = x0 - T0 / kt  # slider position
    s = np.sign(T0) if not stick else 0.0
    y = np.array([x0, v0])
    t = 0.0
    prev = None
    for n in range(max_periods):
        t_end = t + period
        xs = []
        while t < t_end - 1e-14 * period:
            if stick:
                def rhs(tt, yy, w=w):
                    return [yy[1], (P * np.cos(omega * tt) - c * yy[1] - k * yy[0]
                                    - kt * (yy[0] - w)) / m]

                def ev(tt, yy, w=w):
                    return abs(kt * (yy[0] - w)) - fs
            else:
                def rhs(tt, yy, s=s):
                    return [yy[1], (P * np.cos(omega * tt) - c * yy[1] - k * yy[0] - s * fs) / m]

                def ev(tt, yy):
                    return yy[1]
            ev.terminal = True
            ev.direction = 1 if stick else (-s)
            sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-11, atol=1e-13,
                            events=ev, dense_output=True)
            tt = np.linspace(t, sol.t[-1], max(3, int(400 * (sol.t[-1] - t) / period)))
            xs.append(sol.sol(tt)[0])
            y = sol.y[:, -1].copy()
            t = sol.t[-1]
            if sol.status == 1:  # event: switch state
                if stick:
                    s = np.sign(kt * (y[0] - w))
                    stick = False
                else:
                    w = y[0] - s * fs / kt
                    stick = True
        state = np.array([y[0], y[1], kt * (y[0] - w) if stick else s * fs])
        x_all = np.concatenate(xs)
        if prev is not None and np.max(np.abs(state - prev)) <= tol * max(np.max(np.abs(x_all)), 1):
            return float(np.max(np.abs(x_all))), n + 1
        prev = state
    return float(np.max(np.abs(x_all))), max_periods
