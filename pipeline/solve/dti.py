"""Direct time integration (DTI) of lumped models with friction contacts (seed 4.1).

The reference the text uses for its harmonic-balance results: the equations of
motion (seed eq. 20)

    M q'' + C q' + K q = F(t) - sum_c B_c^T f_c(B_c q)

are marched in time with the contact laws of :mod:`microslip.pipeline.friction.laws` held as
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

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from microslip.pipeline.friction.laws import ContactElements
from microslip.pipeline.friction.states import SAMPLE_OPEN, SAMPLE_STICK

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



# =============================================================== validation
def _finite_matrix(name: str, value, n: int | None) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"dti: '{name}' must be a square matrix, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"dti: '{name}' is {arr.shape[0]}x{arr.shape[0]}, expected {n}x{n}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"dti: '{name}' contains NaN or Inf")
    return np.ascontiguousarray(arr)


def _positive(name: str, value, *, allow_zero: bool = False) -> float:
    x = float(value)
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        allowed = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"dti: '{name}' = {value!r} is not allowed; must be finite and {allowed}")
    return x


def _count(name: str, value, minimum: int) -> int:
    if int(value) != value or value < minimum:
        raise ValueError(f"dti: '{name}' = {value!r} is not allowed; must be an integer "
                         f">= {minimum}")
    return int(value)


def _vector(name: str, value, n: int, dtype=float) -> np.ndarray:
    arr = np.zeros(n, dtype=dtype) if value is None else np.asarray(value, dtype=dtype)
    if arr.shape != (n,):
        raise ValueError(f"dti: '{name}' has shape {arr.shape}, expected ({n},)")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"dti: '{name}' contains NaN or Inf")
    return arr


# ==================================================================== model
@dataclass(frozen=True, eq=False)
class _Packed:
    """All contact points of a model flattened for the compiled kernel.

    B: (R, n_dof) stacked kinematics; row0: (P,) first row of each point;
    dim, normal: (P,) tangential dimension and 0/1 variable normal;
    kt: (P, 2) (second column unused for 1D); kn, mu, n0: (P,);
    offsets: (n_contacts + 1,) first point of each contact."""

    B: np.ndarray
    row0: np.ndarray
    dim: np.ndarray
    normal: np.ndarray
    kt: np.ndarray
    kn: np.ndarray
    mu: np.ndarray
    n0: np.ndarray
    offsets: np.ndarray


def _pack(contacts: tuple[tuple[ContactElements, np.ndarray], ...], n: int) -> _Packed:
    rows, row0, dim, normal, kt, kn, mu, n0, offsets = [], [], [], [], [], [], [], [], [0]
    r = 0
    for el, B in contacts:
        c = el.n_components
        for _ in range(el.size):
            row0.append(r)
            r += c
        rows.append(B)
        dim += [el.dim] * el.size
        normal += [int(el.variable_normal)] * el.size
        k2 = np.zeros((el.size, 2))
        k2[:, : el.dim] = el.kt
        k2[:, el.dim:] = 1.0
        kt.append(k2)
        kn.append(el.kn)
        mu.append(el.mu)
        n0.append(el.n0)
        offsets.append(offsets[-1] + el.size)
    if not contacts:
        return _Packed(np.zeros((0, n)), np.zeros(0, np.int64), np.zeros(0, np.int64),
                       np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0), np.zeros(0),
                       np.zeros(0), np.array(offsets))
    return _Packed(
        np.ascontiguousarray(np.vstack(rows)), np.array(row0, np.int64), np.array(dim, np.int64),
        np.array(normal, np.int64), np.vstack(kt), np.concatenate(kn), np.concatenate(mu),
        np.concatenate(n0), np.array(offsets),
    )


@dataclass(frozen=True, eq=False)
class TimeModel:
    """A lumped model ``M q'' + C q' + K q = F(t) - sum_c B_c^T f_c(B_c q)``.

    M, C, K: (n_dof, n_dof) in kg, N s/m, N/m; M symmetric positive definite.
    contacts: pairs (ContactElements, B) with B the real (P * c, n_dof)
    kinematics (rows point-major, components ``[u_1, ..., u_d, (v)]``) as in
    :class:`microslip.pipeline.solve.hbm.Contact`.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    contacts: tuple[tuple[ContactElements, np.ndarray], ...]
    packed: _Packed = field(repr=False)

    @classmethod
    def create(cls, M, K, C=None, contacts: Sequence = ()) -> TimeModel:
        """Validate the matrices and the contact kinematics."""
        K = _finite_matrix("K", K, None)
        n = K.shape[0]
        M = _finite_matrix("M", M, n)
        C = np.zeros((n, n)) if C is None else _finite_matrix("C", C, n)
        if np.abs(M - M.T).max() > 1e-12 * np.abs(M).max():
            raise ValueError("dti: 'M' must be symmetric")
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise ValueError(
                f"dti: 'M' must be positive definite (every DOF needs mass for time "
                f"integration); smallest eigenvalue {np.linalg.eigvalsh(M).min():.3g}"
            ) from None
        pairs = []
        for i, pair in enumerate(contacts):
            if not (isinstance(pair, tuple | list) and len(pair) == 2):
                raise ValueError(f"dti: 'contacts[{i}]' must be a pair (ContactElements, B), "
                                 f"got {type(pair).__name__}")
            el, B = pair
            if not isinstance(el, ContactElements):
                raise ValueError(f"dti: 'contacts[{i}]' elements must be ContactElements, got "
                                 f"{type(el).__name__}")
            Bm = np.asarray(B)
            if np.iscomplexobj(Bm):
                raise ValueError(f"dti: 'contacts[{i}]' kinematics must be real (per-order "
                                 "complex kinematics have no time-domain equivalent)")
            Bm = np.asarray(Bm, dtype=float)
            shape = (el.size * el.n_components, n)
            if Bm.shape != shape:
                raise ValueError(f"dti: 'contacts[{i}]' kinematics has shape {Bm.shape}, "
                                 f"expected (points * components, n_dof) = {shape}")
            if not np.all(np.isfinite(Bm)):
                raise ValueError(f"dti: 'contacts[{i}]' kinematics contains NaN or Inf")
            pairs.append((el, Bm))
        pairs = tuple(pairs)
        return cls(M, C, K, pairs, _pack(pairs, n))

    @classmethod
    def from_harmonic_balance(cls, model) -> TimeModel:
        """The time-domain twin of a lumped :class:`microslip.pipeline.solve.hbm.HarmonicBalance`
        (the same K, M, C for every harmonic order and real kinematics)."""
        lin = model.linear
        if set(lin.sizes) != {lin.n_dof}:
            raise ValueError("dti: the orders have DOFs of their own (a reduced cyclic body): "
                             "no time-domain equivalent")
        for name, mats in (("K", np.array(lin.K)), ("M", np.array(lin.M)),
                           ("C", np.array(lin.C))):
            if np.abs(mats - mats[:1]).max() > 0 or np.abs(mats.imag).max() > 0:
                raise ValueError(f"dti: '{name}' differs between harmonic orders or is complex "
                                 "(cyclic symmetry): no time-domain equivalent")
        contacts = []
        for c in model.contacts:
            if isinstance(c.kinematics, Mapping):
                raise ValueError(f"dti: contact '{c.name}' has per-order kinematics; "
                                 "no time-domain equivalent")
            contacts.append((c.elements, np.asarray(c.kinematics, dtype=float)))
        return cls.create(lin.M[0].real, lin.K[0].real, lin.C[0].real, contacts)

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]

    @property
    def n_points(self) -> int:
        """Contact points over all contacts."""
        return int(self.packed.offsets[-1])


@dataclass(frozen=True, eq=False)
class LoadSteps:
    """The load history of the text's Fig. 13.

    static: (n_dof,) static load F_s, N (e.g. the centrifugal force CF).
    harmonic: (n_dof,) complex amplitude F_1, N: the dynamic load is
        ``Re(F_1 exp(i w tau)) = Re F_1 cos(w tau) - Im F_1 sin(w tau)`` with
        ``tau`` the time since the start of load step 2.
    ramp_time: s, load step 1: F_s grows as ``(1 - cos(pi t / ramp_time)) / 2``
        (quasi-static: no velocity jump at either end), dynamic load off.
    settle_time: s, load step 1 continues with F_s held so that the transient
        of the ramp decays.
    ramp_periods: load step 2: the amplitude of F_1 grows linearly over this many
        excitation periods (an integer, so the steady periods start at phase 0).
    """

    static: np.ndarray
    harmonic: np.ndarray
    ramp_time: float = 0.0
    settle_time: float = 0.0
    ramp_periods: int = 0

    @classmethod
    def create(cls, n_dof: int, *, static=None, harmonic=None, ramp_time: float = 0.0,
               settle_time: float = 0.0, ramp_periods: int = 0) -> LoadSteps:
        n = _count("n_dof", n_dof, 1)
        return cls(
            _vector("static", static, n),
            _vector("harmonic", harmonic, n, complex),
            _positive("ramp_time", ramp_time, allow_zero=True),
            _positive("settle_time", settle_time, allow_zero=True),
            _count("ramp_periods", ramp_periods, 0),
        )

    @classmethod
    def from_excitation(cls, excitation, n_dof: int, **steps) -> LoadSteps:
        """From a :class:`microslip.pipeline.solve.hbm.Excitation` with orders 0 and 1 only."""
        orders = set(excitation.forces)
        if not orders <= {0, 1}:
            raise ValueError(f"dti: excitation orders {sorted(orders)} are not supported; "
                             "allowed: 0 (static) and 1")
        static = excitation.forces.get(0)
        if static is not None and np.abs(np.imag(static)).max() > 0:
            raise ValueError("dti: the static (order 0) excitation must be real")
        return cls.create(n_dof, static=None if static is None else np.real(static),
                          harmonic=excitation.forces.get(1), **steps)

    def dynamic(self, omega: float, tau: np.ndarray) -> np.ndarray:
        """(len(tau), n_dof) dynamic load at full amplitude, N."""
        wt = omega * np.asarray(tau)[:, None]
        return self.harmonic.real * np.cos(wt) - self.harmonic.imag * np.sin(wt)


# ==================================================================== state
@dataclass(frozen=True)
class State:
    """Everything the march needs to continue: kinematics and committed contacts.

    t: s; q, v: (n_dof,) m, m/s; T: (P_all, 2) tangential forces, N (second
    column 0 for 1D); N: (P_all,) normal forces, N; N_raw: (P_all,) ``n0 + kn v``
    (negative: the gap, as a force); g: (P_all, 3) relative displacements
    ``[u_1, u_2, v]``, m; flag: (P_all,) per-point stick/slip/open code.
    """

    t: float
    q: np.ndarray
    v: np.ndarray
    T: np.ndarray
    N: np.ndarray
    N_raw: np.ndarray
    g: np.ndarray
    flag: np.ndarray


def initial_state(model: TimeModel, q0=None, v0=None, *, t0: float = 0.0) -> State:
    """State at rest (or at q0, v0) with the tangential springs unloaded: every
    closed contact sticks from where it is (T = 0), every other one is open."""
    n = model.n_dof
    q = _vector("q0", q0, n)
    v = _vector("v0", v0, n)
    pk = model.packed
    g = _relative(pk, q)
    raw = pk.n0 + pk.kn * g[:, 2] * pk.normal
    N = np.maximum(raw, 0.0)
    flag = np.where(N > 0, SAMPLE_STICK, SAMPLE_OPEN).astype(np.int8)
    return State(float(t0), q, v, np.zeros((pk.n0.size, 2)), N, raw, g, flag)


def _relative(pk: _Packed, q: np.ndarray) -> np.ndarray:
    """(P_all, 3) relative displacements [u_1, u_2, v] of every point, m."""
    gq = pk.B @ q
    g = np.zeros((pk.n0.size, 3))
    for p in range(pk.n0.size):
        r, d = pk.row0[p], pk.dim[p]
        g[p, :d] = gq[r: r + d]
        if pk.normal[p]:
            g[p, 2] = gq[r + d]
    return g


# =================================================================== kernel
@njit(cache=True)
def _point_law(p, gt, gc, Tc, Nc, Nrc, kt, kn_, mu_, n0_, d, has_n, T, D):  # pragma: no cover
    """Return map of one point from its committed state to the trial g.

    Point p of: gt, gc (P, 3) trial and committed ``[u_1, u_2, v]``; Tc (P, 2)
    committed T; Nc, Nrc (P,) committed N and ``n0 + kn v``; kt (P, 2), kn,
    mu, n0 (P,) parameters. Writes T (2,) and D (3, 3) =
    d[T_1, T_2, N] / d[u_1, u_2, v]; returns (N, n0 + kn v, state code)."""
    for i in range(3):
        for j in range(3):
            D[i, j] = 0.0
    T[0] = 0.0
    T[1] = 0.0
    kn = kn_[p]
    mu = mu_[p]
    nr = n0_[p] + kn * gt[p, 2] if has_n else n0_[p]
    if nr <= 0.0:
        return 0.0, nr, 2  # OPEN
    if has_n:
        D[2, 2] = kn
    tp0 = 0.0
    tp1 = 0.0
    if has_n and Nc[p] <= 0.0:
        # re-contact inside the step at fraction s; stick starts where the gap closed
        nrc = Nrc[p]
        s = nrc / (nrc - nr)
        dsdv = nrc * kn / ((nrc - nr) * (nrc - nr))
        for j in range(d):
            du = gt[p, j] - gc[p, j]
            tj = kt[p, j] * (1.0 - s) * du
            D[j, j] = kt[p, j] * (1.0 - s)
            D[j, 2] = -kt[p, j] * du * dsdv
            if j == 0:
                tp0 = tj
            else:
                tp1 = tj
    else:
        tp0 = Tc[p, 0] + kt[p, 0] * (gt[p, 0] - gc[p, 0])
        D[0, 0] = kt[p, 0]
        if d == 2:
            tp1 = Tc[p, 1] + kt[p, 1] * (gt[p, 1] - gc[p, 1])
            D[1, 1] = kt[p, 1]
    norm = np.sqrt(tp0 * tp0 + tp1 * tp1)
    lim = mu * nr
    if norm <= lim:
        T[0] = tp0
        T[1] = tp1
        return nr, nr, 0  # STICK
    ratio = lim / norm
    n_0 = tp0 / norm
    n_1 = tp1 / norm
    T[0] = ratio * tp0
    T[1] = ratio * tp1
    for col in range(3):
        proj = n_0 * D[0, col] + n_1 * D[1, col]
        D[0, col] = ratio * (D[0, col] - n_0 * proj)
        D[1, col] = ratio * (D[1, col] - n_1 * proj)
    if has_n:
        D[0, 2] += mu * n_0 * kn
        D[1, 2] += mu * n_1 * kn
    return nr, nr, 1  # SLIP


@njit(cache=True)
def _solve_inplace(A, b):  # pragma: no cover
    """Solve A x = b by Gaussian elimination with partial pivoting; x into b,
    A destroyed. Small dense systems: no allocation, no LAPACK call overhead."""
    n = b.size
    for k in range(n):
        piv = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                piv = i
        if piv != k:
            for j in range(n):
                A[k, j], A[piv, j] = A[piv, j], A[k, j]
            b[k], b[piv] = b[piv], b[k]
        akk = A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] / akk
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= A[k, j] * b[j]
        b[k] = s / A[k, k]


@njit(cache=True)
def _relative_motion(B, x, row0, dim, normal, gq, out):  # pragma: no cover
    """Per point (u1, u2, v) of the DOF vector x (displacements or velocities): gq = B x,
    then out[p] = its point's rows, 0 for a component the point does not have."""
    n = x.size
    for i in range(gq.size):
        s = 0.0
        for j in range(n):
            s += B[i, j] * x[j]
        gq[i] = s
    for p in range(row0.size):
        r0 = row0[p]
        d = dim[p]
        out[p, 0] = gq[r0]
        out[p, 1] = gq[r0 + 1] if d == 2 else 0.0
        out[p, 2] = gq[r0 + d] if normal[p] else 0.0


@njit(cache=True)
def _residual(a1, h, q, v, a, M, C, K, B, row0, dim, normal, kt, kn, mu, n0,
              Tc, Nc, Nrc, gc, Fk, want_J, r, J, qt, vt, dq, Tt, Nt, Nrt, st, gt, gq, Dp,
              tmp):  # pragma: no cover
    """Residual ``M a1 + C v1 + K q1 + B^T f(B q1) - F`` of a Newmark step of
    length h written in the end acceleration a1 (no cancellation however short
    the step): ``dq = h v + h^2 (a + a1) / 4``, ``q1 = q + dq``,
    ``v1 = v + h (a + a1) / 2``. Fills qt, vt, dq, the trial contact state
    (Tt, Nt, Nrt, st, gt) and, if want_J, J = dR/da1. Returns the force
    scale (largest term)."""
    n = q.size
    h4 = 0.25 * h * h
    for j in range(n):
        dq[j] = h * v[j] + h4 * (a[j] + a1[j])
        qt[j] = q[j] + dq[j]
        vt[j] = v[j] + 0.5 * h * (a[j] + a1[j])
    scale = 1e-300
    for i in range(n):
        ma = 0.0
        cv = 0.0
        kq = 0.0
        for j in range(n):
            ma += M[i, j] * a1[j]
            cv += C[i, j] * vt[j]
            kq += K[i, j] * qt[j]
            if want_J:
                J[i, j] = M[i, j] + 0.5 * h * C[i, j] + h4 * K[i, j]
        r[i] = ma + cv + kq - Fk[i]
        scale = max(scale, abs(ma), abs(cv), abs(kq), abs(Fk[i]))
    _relative_motion(B, qt, row0, dim, normal, gq, gt)
    for p in range(row0.size):
        r0 = row0[p]
        d = dim[p]
        hn = normal[p]
        N, nr, s = _point_law(p, gt, gc, Tc, Nc, Nrc, kt, kn, mu, n0, d, hn, tmp, Dp)
        Tt[p, 0] = tmp[0]
        Tt[p, 1] = tmp[1]
        Nt[p] = N
        Nrt[p] = nr
        st[p] = s
        c = d + hn
        for a_ in range(c):
            fa = tmp[a_] if a_ < d else N
            if fa != 0.0:
                for i in range(n):
                    r[i] += B[r0 + a_, i] * fa
            scale = max(scale, abs(fa))
        if want_J and s != 2:
            for a_ in range(c):
                ia = a_ if a_ < d else 2
                for b_ in range(c):
                    ib = b_ if b_ < d else 2
                    dab = Dp[ia, ib] * h4
                    if dab == 0.0:
                        continue
                    for i in range(n):
                        bai = B[r0 + a_, i] * dab
                        if bai == 0.0:
                            continue
                        for j in range(n):
                            J[i, j] += bai * B[r0 + b_, j]
    return scale


@njit(cache=True)
def _solve_step(h, Fk, q, v, a, M, C, K, B, row0, dim, normal, kt, kn, mu, n0,
                Tc, Nc, Nrc, gc, rtol, max_iter, a1, qt, vt, dq, Tt, Nt, Nrt, st, gt, work,
                J, gq, Dp, tmp):  # pragma: no cover
    """Newton on one Newmark step of length h from the committed state (the
    unknown is the end acceleration a1; predictor a1 = a). On success the end
    state is in a1, qt, vt, dq and the trial contact arrays. Returns
    (iterations, converged)."""
    n = q.size
    r, da, trial = work[0], work[1], work[2]
    for j in range(n):
        a1[j] = a[j]
    small = False
    for it in range(max_iter):
        scale = _residual(a1, h, q, v, a, M, C, K, B, row0, dim, normal, kt, kn, mu, n0,
                          Tc, Nc, Nrc, gc, Fk, True, r, J, qt, vt, dq, Tt, Nt, Nrt, st, gt, gq,
                          Dp, tmp)
        rn = 0.0
        for j in range(n):
            rn = max(rn, abs(r[j]))
        if rn <= rtol * scale or small:
            return it + 1, True
        for j in range(n):
            da[j] = -r[j]
        _solve_inplace(J, da)
        alpha = 1.0
        if it >= 6:  # damp a Newton cycle between two active sets
            for _ in range(12):
                for j in range(n):
                    trial[j] = a1[j] + alpha * da[j]
                _residual(trial, h, q, v, a, M, C, K, B, row0, dim, normal, kt, kn, mu, n0,
                          Tc, Nc, Nrc, gc, Fk, False, r, J, qt, vt, dq, Tt, Nt, Nrt, st, gt,
                          gq, Dp, tmp)
                rt = 0.0
                for j in range(n):
                    rt = max(rt, abs(r[j]))
                if rt < (1.0 - 1e-4 * alpha) * rn:
                    break
                alpha *= 0.5
        big = 1e-300
        step = 0.0
        for j in range(n):
            a1[j] += alpha * da[j]
            big = max(big, abs(a1[j]))
            step = max(step, abs(alpha * da[j]))
        small = step <= 1e-15 * big
    return max_iter, False


@njit(cache=True)
def _hermite(s, h, g0, g1, d0, d1):  # pragma: no cover
    """Cubic Hermite value and time derivative at fraction s of a step of
    length h between (g0, rate d0) and (g1, rate d1)."""
    s2 = s * s
    s3 = s2 * s
    val = ((2 * s3 - 3 * s2 + 1) * g0 + (s3 - 2 * s2 + s) * h * d0
           + (-2 * s3 + 3 * s2) * g1 + (s3 - s2) * h * d1)
    der = ((6 * s2 - 6 * s) * g0 + (3 * s2 - 4 * s + 1) * h * d0
           + (-6 * s2 + 6 * s) * g1 + (3 * s2 - 2 * s) * h * d1) / h
    return val, der


@njit(cache=True)
def _event_value(kind, s, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim, normal,
                 Tc):  # pragma: no cover
    """Event function of one point at fraction s of the step (a sign change is
    a transition): kind 0 ``n0 + kn v`` (closing, opening); kind 1
    ``|Tp| - mu N`` (stick -> slip); kind 2 ``kt u' . e - mu kn v'`` with e the
    slip direction (slip -> stick: the force no longer keeps up with the
    slip limit, e.g. a reversal)."""
    vv, vd = _hermite(s, h, gc[p, 2], gt[p, 2], gd0[p, 2], gd1[p, 2])
    if normal[p] == 0:
        vv = 0.0
        vd = 0.0
    nr = n0[p] + kn[p] * vv
    if kind == 0:
        return nr
    if kind == 1:
        tn = 0.0
        for j in range(dim[p]):
            u, _ = _hermite(s, h, gc[p, j], gt[p, j], gd0[p, j], gd1[p, j])
            tj = Tc[p, j] + kt[p, j] * (u - gc[p, j])
            tn += tj * tj
        return np.sqrt(tn) - mu[p] * nr
    tnorm = np.sqrt(Tc[p, 0] ** 2 + Tc[p, 1] ** 2)
    f = 0.0
    for j in range(dim[p]):
        _, ud = _hermite(s, h, gc[p, j], gt[p, j], gd0[p, j], gd1[p, j])
        f += kt[p, j] * ud * Tc[p, j] / tnorm
    return f - mu[p] * kn[p] * vd


@njit(cache=True)
def _first_event(h, v, vt, B, row0, dim, normal, kt, kn, mu, n0, Tc, Nc, sc, gc, gt,
                 gd0, gd1, gq):  # pragma: no cover
    """Earliest contact transition inside a step of length h, as a fraction in
    (0, 1) located by bisection on the cubic Hermite interpolant of the
    relative motion; 2.0 if no event function changes sign over the step."""
    _relative_motion(B, v, row0, dim, normal, gq, gd0)
    _relative_motion(B, vt, row0, dim, normal, gq, gd1)
    first = 2.0
    for p in range(row0.size):
        for kind in range(3):
            if kind == 0 and normal[p] == 0:
                continue
            if kind == 1 and not (Nc[p] > 0.0 and sc[p] == 0):
                continue
            if kind == 2 and not (Nc[p] > 0.0 and sc[p] == 1
                                  and Tc[p, 0] ** 2 + Tc[p, 1] ** 2 > 0.0):
                continue
            f0 = _event_value(kind, 0.0, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                              normal, Tc)
            f1 = _event_value(kind, 1.0, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                              normal, Tc)
            if (f0 > 0.0) == (f1 > 0.0):
                continue
            lo, hi = 0.0, 1.0
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                fm = _event_value(kind, mid, h, p, gc, gt, gd0, gd1, kt, kn, mu, n0, dim,
                                  normal, Tc)
                if (fm > 0.0) == (f0 > 0.0):
                    lo = mid
                else:
                    hi = mid
            first = min(first, 0.5 * (lo + hi))
    return first


@njit(cache=True)
def _commit(h, Fprev, Fend, q, v, a, a1, qt, vt, dq, C, kt, dim, Tc, Nc, Nrc, gc, sc, Tt, Nt,
            Nrt, st, gt, energy, wf, wn):  # pragma: no cover
    """Accept a step: the end state becomes the committed one, and the step's
    energies are added: energy[0] external ``dq . F_avg``, energy[1] viscous
    ``h v_avg' C v_avg``; wf, wn (P,) friction ``T_avg . Dw`` and normal
    ``N_avg Dv`` work."""
    n = q.size
    ext = 0.0
    visc = 0.0
    for i in range(n):
        ext += dq[i] * 0.5 * (Fprev[i] + Fend[i])
        s = 0.0
        for j in range(n):
            s += C[i, j] * 0.5 * (v[j] + vt[j])
        visc += h * 0.5 * (v[i] + vt[i]) * s
    for j in range(n):
        q[j] = qt[j]
        v[j] = vt[j]
        a[j] = a1[j]
    energy[0] += ext
    energy[1] += visc
    for p in range(Tc.shape[0]):
        w = 0.0
        for j in range(dim[p]):
            dw = (gt[p, j] - gc[p, j]) - (Tt[p, j] - Tc[p, j]) / kt[p, j]
            w += 0.5 * (Tt[p, j] + Tc[p, j]) * dw
        wf[p] += w
        wn[p] += 0.5 * (Nt[p] + Nc[p]) * (gt[p, 2] - gc[p, 2])
        Tc[p, 0] = Tt[p, 0]
        Tc[p, 1] = Tt[p, 1]
        Nc[p] = Nt[p]
        Nrc[p] = Nrt[p]
        sc[p] = st[p]
        for j in range(3):
            gc[p, j] = gt[p, j]


@njit(cache=True)
def _march(q, v, a, M, C, K, B, row0, dim, normal, kt, kn, mu, n0, Tc, Nc, Nrc, gc, sc,
           F, dt, rtol, max_iter, max_events, min_fraction, q_out, v_out, T_out, N_out, s_out,
           g_out, e_out, wf_out, wn_out):  # pragma: no cover
    """Advance F.shape[0] - 1 steps of dt in place from the committed state
    (q, v, a, Tc, Nc, Nrc, gc, sc); F: (n + 1, n_dof) load at the step ends,
    linear in between. A step in which a contact changes state is split at the
    transition (at most max_events times per step, not closer than
    min_fraction to either end) so that no kink of the contact force falls
    inside a step. Records the states 0..n and the cumulative energies
    (e_out (n + 1, 2) external and viscous, wf_out, wn_out (n + 1, P)).
    Returns (Newton iterations, sub-steps added, index of a failed step or -1)."""
    n = q.size
    P = row0.size
    R = B.shape[0]
    steps = F.shape[0] - 1
    a1 = np.empty(n)
    qt = np.empty(n)
    vt = np.empty(n)
    dq = np.empty(n)
    work = np.empty((3, n))
    J = np.empty((n, n))
    Tt = np.empty((P, 2))
    Nt = np.empty(P)
    Nrt = np.empty(P)
    st = np.empty(P, dtype=np.int8)
    gt = np.empty((P, 3))
    gq = np.empty(R)
    gd0 = np.empty((P, 3))
    gd1 = np.empty((P, 3))
    Dp = np.empty((3, 3))
    tmp = np.empty(2)
    Fs = np.empty(n)
    Fe = np.empty(n)
    energy = np.zeros(2)
    wf = np.zeros(P)
    wn = np.zeros(P)
    total = 0
    added = 0
    for k in range(steps + 1):
        if k > 0:
            pos = 0.0  # fraction of the grid step done
            splits = 0
            for j in range(n):
                Fs[j] = F[k - 1, j]
            while True:
                h = (1.0 - pos) * dt
                its, ok = _solve_step(h, F[k], q, v, a, M, C, K, B, row0, dim, normal, kt,
                                      kn, mu, n0, Tc, Nc, Nrc, gc, rtol, max_iter, a1, qt, vt,
                                      dq, Tt, Nt, Nrt, st, gt, work, J, gq, Dp, tmp)
                total += its
                if not ok:
                    return total, added, k
                s = 2.0
                if splits < max_events:
                    s = _first_event(h, v, vt, B, row0, dim, normal, kt, kn, mu, n0, Tc, Nc,
                                     sc, gc, gt, gd0, gd1, gq)
                if min_fraction < s < 1.0 - min_fraction:
                    frac = pos + s * (1.0 - pos)
                    for j in range(n):
                        Fe[j] = F[k - 1, j] + frac * (F[k, j] - F[k - 1, j])
                    its, ok = _solve_step(s * h, Fe, q, v, a, M, C, K, B, row0, dim, normal,
                                          kt, kn, mu, n0, Tc, Nc, Nrc, gc, rtol, max_iter, a1,
                                          qt, vt, dq, Tt, Nt, Nrt, st, gt, work, J, gq, Dp,
                                          tmp)
                    total += its
                    if not ok:
                        return total, added, k
                    _commit(s * h, Fs, Fe, q, v, a, a1, qt, vt, dq, C, kt, dim, Tc, Nc, Nrc,
                            gc, sc, Tt, Nt, Nrt, st, gt, energy, wf, wn)
                    for j in range(n):
                        Fs[j] = Fe[j]
                    pos = frac
                    splits += 1
                    added += 1
                    continue
                _commit(h, Fs, F[k], q, v, a, a1, qt, vt, dq, C, kt, dim, Tc, Nc, Nrc, gc, sc,
                        Tt, Nt, Nrt, st, gt, energy, wf, wn)
                break
        q_out[k] = q
        v_out[k] = v
        T_out[k] = Tc
        N_out[k] = Nc
        s_out[k] = sc
        g_out[k] = gc
        e_out[k] = energy
        wf_out[k] = wf
        wn_out[k] = wn
    return total, added, -1



# =============================================================== histories
@dataclass(frozen=True)
class ContactHistory:
    """Time history of one contact's P points over n + 1 instants.

    T: (n + 1, P, d) tangential forces, N; N: (n + 1, P) normal forces, N;
    u: (n + 1, P, d), v: (n + 1, P) relative displacements, m (v = 0 for the
    constant-load laws); state: (n + 1, P) int8 STICK/SLIP/OPEN codes
    (:data:`microslip.pipeline.friction.states.SAMPLE_STICK` ...)."""

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


def _march_loads(model: TimeModel, start: State, F: np.ndarray, dt: float, *,
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
    total, events, failed = _march(
        q, v, a, model.M, model.C, model.K, pk.B, pk.row0, pk.dim, pk.normal, pk.kt, pk.kn,
        pk.mu, pk.n0, Tc, Nc, Nrc, gc, sc, np.ascontiguousarray(F, dtype=float), float(dt),
        float(rtol), int(max_iter), int(max_events), float(min_fraction), q_out, v_out, T_out,
        N_out, s_out, g_out,
        e_out, wf_out, wn_out,
    )
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
    dt = _positive("dt", dt)
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
    return _march_loads(model, start, F, dt)


# =============================================================== load steps
def _check_loads(model: TimeModel, loads: LoadSteps) -> None:
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
    _check_loads(model, loads)
    omega = _positive("omega", omega)
    ns = _count("steps_per_period", steps_per_period, 8)
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
        step1 = _march_loads(model, state, F, t1 / n1)
        state = step1.end
    if loads.ramp_periods > 0:
        n2 = ns * loads.ramp_periods
        tau = dt * np.arange(n2 + 1)
        F = loads.static + (tau / tau[-1])[:, None] * loads.dynamic(omega, tau)
        step2 = _march_loads(model, State(0.0, *_fields(state)), F, dt)
    return step1, step2


def _fields(s: State) -> tuple:
    return s.q, s.v, s.T, s.N, s.N_raw, s.g, s.flag


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
        return harmonic_coefficients(self.trajectory.q[:-1], _count("H", H, 0))


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
    _check_loads(model, loads)
    omega = _positive("omega", omega)
    ns = _count("steps_per_period", steps_per_period, 8)
    tol = _positive("tol", tol)
    max_periods = _count("max_periods", max_periods, 1)
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
        tr = _march_loads(model, State(0.0, *_fields(state)), F, dt)
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
    H = _count("harmonics", harmonics, 0)
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
    ns = [_count("steps_per_period", n, 8) for n in steps_per_period]
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
