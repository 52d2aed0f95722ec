"""Direct time integration (DTI) of lumped models with friction contacts (Firrone & Zucca 4.1).

time_model   M, C, K, the contacts packed for the kernel, the two load steps
kernel       the compiled march: return map per point, Newmark step, Newton on the state
march        trajectories with contact histories, the two load steps
steady       steady states period by period, the energy balance, frequency responses

The reference the text uses for its harmonic-balance results: the equations of
motion (Firrone & Zucca eq. 20)

    M q'' + C q' + K q = F(t) - sum_c B_c^T f_c(B_c q)

are marched in time with the contact laws of :mod:`microslip.laws.coulomb` held as
internal state (stick, slip, lift-off), and the load is applied in the text's
two load steps (Fig. 13): a quasi-static ramp of the static load (centrifugal
force) with the dynamic load off, then a harmonic excitation whose amplitude
grows linearly, the static load held. Period by period integration then runs
until the state at the start of a period repeats (the steady state).

Integrator
----------
Newmark average acceleration (trapezoidal rule, gamma = 1/2, beta = 1/4) with a
fixed step and a full Newton iteration per step on the contact state, with the
consistent tangent of the return map. Chosen over an explicit scheme because
the contact stiffnesses (kt, kn) may be far stiffer than the structure: the
implicit rule is unconditionally stable, second order, and conserves a discrete
energy exactly, so the energy balance below is an identity of the scheme rather
than an approximation (a check of the implementation).

Contact state per point (updated ONCE per accepted step, from the committed
state of the previous step, never from a Newton iterate):

    N = max(n0 + kn v, 0)                       (kn = 0 for the laws A, C)
    predictor   Tp = T_prev + kt (u - u_prev)
    re-contact  Tp = kt (1 - s) (u - u_prev) if the contact was open and
                closes at fraction s of the step (v linear in the step):
                a new stick starts where the gap closed
    open        N = 0 -> T = 0
    stick       |Tp| <= mu N -> T = Tp
    slip        otherwise -> T = mu N Tp / |Tp|   (radial return, 2D)

In the time domain the coupled/uncoupled forms of :class:`ContactElements`
coincide: ``n0`` is N0 (the preload, ``v`` measured from the preloaded state)
or ``kn * interference`` (``v`` the full relative normal displacement).

Accuracy. A kink of the contact force (stick <-> slip, lift-off, re-contact)
inside a step would cost O(dt^2) locally with a constant that jumps with the
kink's position in the step, so the step-size convergence would be second
order only on average (measured: orders 2.5, 1.6, 1.9 on the Jenkins
oscillator). Each accepted step is therefore checked for a transition (sign
change of an event function on the cubic Hermite interpolant of the relative
motion, located by bisection) and split there; the step is written in the
end acceleration so that sub-steps of any length are free of cancellation.
The periodic response then converges at second order (measured 2.45, 2.16,
2.04, 2.01 on halving from 64 to 2048 steps per period):
:func:`step_convergence` prints the table. The excitation is linear in time
inside a split step (O(dt^2) on the load, O(dt^3) on the motion).

Energy over a step (exact for the trapezoidal rule, Dq = dt (v_n + v_n+1) / 2):

    Dq . F_avg = D(1/2 v'Mv + 1/2 q'Kq) + dt v_avg' C v_avg
                 + sum_p T_avg . Du + N_avg Dv

and ``T_avg . Du = D(|T|^2 / 2 kt) + T_avg . Dw`` with the slip increment
``Dw = Du - DT / kt``: the friction dissipation is ``sum T_avg . Dw`` (>= 0).

Units: SI (m, kg, s, N); angular frequency in rad/s.
"""

from .march import ContactHistory, Trajectory, integrate, load_steps
from .steady import (
    EnergyBalance,
    FrequencyResponse,
    SteadyState,
    StepConvergence,
    energy_balance,
    frequency_response,
    harmonic_coefficients,
    hermite_peak,
    steady_state,
    step_convergence,
)
from .time_model import LoadSteps, State, TimeModel, initial_state

__all__ = [
    "ContactHistory",
    "EnergyBalance",
    "FrequencyResponse",
    "LoadSteps",
    "State",
    "SteadyState",
    "StepConvergence",
    "TimeModel",
    "Trajectory",
    "energy_balance",
    "frequency_response",
    "harmonic_coefficients",
    "hermite_peak",
    "initial_state",
    "integrate",
    "load_steps",
    "steady_state",
    "step_convergence",
]
