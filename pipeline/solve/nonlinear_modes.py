"""Nonlinear modes of a friction-damped structure: the extended periodic motion concept
(Krack 2015, "Nonlinear modal analysis of nonconservative systems").

The damped free vibration decays, so it is not periodic; adding a negative mass-
proportional damping ``-xi M dq/dt`` that replaces, over a cycle, the energy the contacts
and the viscous damping take makes it periodic. Its harmonic balance is the forced one
without dynamic loads (the static ones stay: the coupled static/dynamic balance), with

    D_n(w, xi) = K_n - (n w)^2 M_n + i n w (C_n - xi M_n),

and three more unknowns than equations are closed by two conditions: the fundamental's
mass-normalized amplitude is the modal amplitude ``a`` (the continuation parameter, as
log10 a), ``X_1^H M_1 X_1 = a^2`` over every DOF (the condensed ones recovered), and the
phase of one contact DOF's fundamental is zero. At each level: the natural frequency w(a)
[rad/s], the modal damping ratio ``zeta = xi / (2 w)`` and the harmonics of the motion.
In the linear limit (contacts stuck or open) w is the linear natural frequency and ``xi
= psi^H C psi`` (psi mass-normalized), ``2 zeta w`` of a proportionally damped mode.

The balance is condensed on the contact DOFs per order as the forced one is (exact), its
condensation made at each (w, xi) with the factors kept for both derivatives. Newton solves
the balance's Jacobian bordered by the two conditions and the two unknowns (w, xi): dense,
or as the forced balance's structured Jacobian (``solve.jacobian.BorderedJacobian``: GMRES
on the per-order factors, the borders by block elimination) on large models.

The levels are continued by pseudo-arclength in log10 a with the static unknowns weighted
1 / STATIC_WEIGHT in its metric: once every point of a friction-held body (a damper) slips
during the cycle, its static position is nearly indeterminate (a Jenkins slider's force
history does not depend on its mean position), the Jacobian at a fixed level nearly
singular along that static drift, and with the static unknowns weighted as the others the
tangent follows the drift (measured on 15_blisk_damper at 7.3 x the damper mass: 423
points, most of them retracing the drift between two kinks; weighted, 26). Stepping in a
instead (natural continuation) passes the drift too, but not the corner where a contact
lifts off at once, which arclength crosses.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import scipy.linalg as sla

from .arclength import arclength
from .branch import Branch
from .condensation import Condensed
from .hbm import HarmonicBalance
from .jacobian import BorderedJacobian
from .linear import OperatingPoint
from .newton import DEFAULT, Settings, newton
from .response import Response

LN10 = np.log(10.0)
#: The linear modes are found by a dense eigen-solve up to this many DOFs of the order (a
#: lumped model or reduced bodies: a few hundred); a larger order is refused, saying so.
DENSE_EIGEN = 3000
#: The static unknowns' scale in the continuation's metric (the arc length, Newton's step
#: cap), against 1 for the others: the static part may drift along its near-null direction
#: (see the module) without spending the steps.
STATIC_WEIGHT = 1e3


@dataclass(frozen=True)
class LinearMode:
    """A linear mode of the fundamental order (contacts stuck or removed).

    omega: natural frequency [rad/s]; shape: (n_1,) complex mode shape of every DOF of the
    order (the model's order, not reordered), mass-normalized (``shape^H M_1 shape = 1``,
    [kg^-1/2]); xi: ``shape^H C_1 shape`` [1/s], the linear mode's ``2 zeta omega``."""

    omega: float
    shape: np.ndarray
    xi: float


@dataclass(frozen=True)
class Backbone:
    """A nonlinear mode over amplitude levels (m points).

    amplitude: (m,) modal amplitude a [kg^1/2 m] (the fundamental's mass-normalized
    amplitude); omega: (m,) natural frequency [rad/s]; xi: (m,) the self-excitation [1/s];
    x: (m, n) the balance's unknowns (contact DOFs' coefficients, DOF-major) at each level;
    branch: the continuation's record (status, message, iterations); solver: its problem
    (for a level between the computed ones, :meth:`at`)."""

    amplitude: np.ndarray
    omega: np.ndarray
    xi: np.ndarray
    x: np.ndarray
    branch: Branch
    solver: ModeSolver

    def at(self, amplitude: float) -> tuple[np.ndarray, float, float] | None:
        """(x, omega, xi) of the level ``amplitude`` within the computed range, solved by
        Newton from the neighbouring levels (interpolated in log a, the shape normalized);
        None out of range or where Newton fails."""
        a = self.amplitude
        if not (len(a) and a.min() <= amplitude <= a.max()):
            return None
        i = int(np.clip(np.searchsorted(a, amplitude) - 1, 0, len(a) - 2)) if len(a) > 1 \
            else 0
        ys = [self.solver.scaled(x, w, xi, b) for x, w, xi, b in
              zip(self.x[i:i + 2], self.omega[i:i + 2], self.xi[i:i + 2], a[i:i + 2])]
        t = 0.0 if len(ys) == 1 else np.log(amplitude / a[i]) / np.log(a[i + 1] / a[i])
        return self.solver.level(amplitude, (1.0 - t) * ys[0] + t * ys[-1])

    @property
    def damping_ratio(self) -> np.ndarray:
        """(m,) modal damping ratio zeta = xi / (2 omega)."""
        return self.xi / (2.0 * self.omega)

    @property
    def status(self) -> str:
        return self.branch.status

    def response(self) -> ModalResponse:
        """The levels as a solved branch of the model (parameter log10 a, every point at
        its own (omega, xi)): outputs, contact states and maps as a forced response's."""
        n = len(self.amplitude)
        b = Branch(self.branch.parameter, np.log10(self.amplitude), self.x,
                   np.asarray(self.branch.residuals)[:n], np.asarray(self.branch.iterations)[:n],
                   status=self.branch.status, message=self.branch.message)
        return ModalResponse(self.solver.modal.model, b, self.solver.modal.point,
                             tuple(self.solver.modal.at(w, xi)
                                   for w, xi in zip(self.omega, self.xi)))


class ModalBalance:
    """The autonomous balance of a :class:`HarmonicBalance` (no dynamic loads) with the
    self-excitation ``-xi M dq/dt``, at a fixed operating point (mass multiplier, preload);
    the static loads at each level's frequency (a rotating load tied to the frequency by
    the engine order follows the mode's, as it follows the excitation's in an FRF).

    ``fundamental`` is the harmonic order whose amplitude and phase are prescribed (1: the
    harmonic the mode's own frequency is)."""

    def __init__(self, model: HarmonicBalance, point: OperatingPoint, fundamental: int = 1):
        h = model.harmonics
        if fundamental not in h.dynamic_orders:
            raise ValueError(f"nonlinear modes: harmonic order {fundamental} is not kept "
                             f"(orders {list(h.orders)}); the mode's fundamental must be")
        self.model = model
        self.point = point
        self.fundamental = fundamental
        self._k1 = h.orders.index(fundamental)
        self._lin = model.reordered()
        self._M = self._lin.linear.mass(point)

    # ---------------------------------------------------------- the balance
    def at(self, omega: float, xi: float) -> OperatingPoint:
        """The operating point of a level: no dynamic load, the self-excitation xi."""
        return replace(self.point, omega=omega, excitation=0.0, xi=xi)

    def forced(self, omega: float, excitation: float) -> OperatingPoint:
        """The forced operating point at this frequency and excitation multiplier (the
        mass multiplier and preload of the mode's)."""
        return replace(self.point, omega=omega, excitation=excitation, xi=None)

    def condensed(self, omega: float, xi: float) -> Condensed:
        """The linear part condensed on the contact DOFs at (omega, xi), with its
        derivative by omega and the factors kept (for the one by xi)."""
        return self.model.condensed(self.at(omega, xi), "frequency")

    def balance(self, x: np.ndarray, omega: float, xi: float, jacobian: bool = True,
                structured: bool = False):
        """R(x) (n,), and with ``jacobian`` dR/dx (n, n) dense or (``structured``) a
        :class:`~microslip.solve.jacobian.BalanceJacobian`, dR/domega (n,), dR/dxi (n,) and
        dD/dxi per order (else None each); the condensation (for the amplitude condition).
        dR/dxi has no load term: the condensed loads of the dynamic orders are zero (no
        dynamic load) and order 0 has no xi."""
        h = self.model.harmonics
        point = self.at(omega, xi)
        # by "frequency" always: one condensation (cached) serves the residual and q
        R, J, R_w = self.model.residual(x, point, "frequency", jacobian, structured)
        lin = self.model.condensed(point, "frequency")
        if not jacobian:
            return R, None, None, None, None, lin
        X = np.array([h.to_complex(x.reshape(self.model.dofs.size, h.n_coeffs))[o]
                      for o in h.orders])
        d_xi = self._lin.linear.d_dynamic_stiffness(point, "xi")
        R_xi = h.real_vector(lin.derivative_product(d_xi, X)).ravel()
        return R, J, R_w, R_xi, d_xi, lin

    def fundamental_of(self, x: np.ndarray) -> np.ndarray:
        """(n_contact,) complex fundamental of the contact DOFs."""
        h = self.model.harmonics
        return h.to_complex(x.reshape(self.model.dofs.size, h.n_coeffs))[self.fundamental]

    def modal_mass(self, lin: Condensed, psi: np.ndarray,
                   d_xi: list[np.ndarray | None] | None = None
                   ) -> tuple[float, np.ndarray, float, float]:
        """q = psi^H M_1 psi over every DOF of the fundamental's order (the condensed ones
        recovered, ``psi_i = -Y psi_c``: no dynamic load), its gradient by the contact
        DOFs' complex amplitudes (``dq = 2 Re(g^H dpsi)``) and, given ``d_xi`` (dD/dxi per
        order), its derivatives by omega and xi (through Y; else 0, 0)."""
        k, nc = self._k1, self.model.dofs.size
        M = self._M[k]
        W = lin.Y[k] @ psi
        v = M[nc:, :nc] @ psi - M[nc:, nc:] @ W  # (M_ic psi - M_ii W)
        g = M[:nc, :nc] @ psi - M[:nc, nc:] @ W - lin.Y[k].conj().T @ v
        q = float(np.real(np.vdot(psi, g)))
        if d_xi is None or lin.lus[k] is None:  # not asked, or nothing condensed
            return q, g, 0.0, 0.0
        dD_w = lin.dS[k].dD if lin.dS is not None and lin.dS[k] is not None else None
        dq = []
        for dD in (dD_w, d_xi[k]):
            if dD is None:
                dq.append(0.0)
                continue
            dW = sla.lu_solve(lin.lus[k], dD[nc:, :nc] @ psi - dD[nc:, nc:] @ W,
                              check_finite=False)
            dq.append(float(-2.0 * np.real(np.vdot(v, dW))))
        return q, g, dq[0], dq[1]

    # --------------------------------------------------------- at a level
    def recovered(self, lin: Condensed, x: np.ndarray) -> list[np.ndarray]:
        """Per order the (n_k,) complex amplitudes of every DOF of the order, reordered
        (contact DOFs first; ``reordered().index`` maps them back): the condensed ones
        recovered at the condensation's (omega, xi)."""
        h = self.model.harmonics
        X = h.to_complex(x.reshape(self.model.dofs.size, h.n_coeffs))
        return [np.concatenate([X[o], z - Y @ X[o]])
                for o, Y, z in zip(h.orders, lin.Y, lin.z)]

    def energies(self, x: np.ndarray, omega: float, xi: float,
                 contacts: list | None = None) -> dict[str, float]:
        """Work per cycle [J] at a level: "modal", the self-excitation's input
        ``pi omega xi sum_n n^2 X_n^H M_n X_n``; "viscous", what C takes; "friction" and
        "normal", what the contacts take (``contacts``: their responses there, if made).
        On a converged mode the first is the sum of the others (the periodic motion's
        energy balance)."""
        lin = self.condensed(omega, xi)
        X = self.recovered(lin, x)
        orders = self._lin.linear.orders
        inputs = sum(np.pi * omega * o**2 * float(np.real(np.vdot(Xk, M @ Xk)))
                     for o, Xk, M in zip(orders, X, self._M))
        viscous = sum(np.pi * omega * o**2 * float(np.real(np.vdot(Xk, C @ Xk)))
                      for o, Xk, C in zip(orders, X, self._lin.linear.C))
        resp = contacts if contacts is not None else \
            self.model.contact_response(x, self.at(omega, xi))
        return {"modal": xi * inputs, "viscous": viscous,
                "friction": float(sum(r.dissipation.sum() for r in resp)),
                "normal": float(sum(r.normal_work.sum() for r in resp))}

    def modal_force(self, x: np.ndarray, omega: float, xi: float, amplitude: float
                    ) -> complex:
        """psi_1^H F_1: the projection of the model's excitation (its fundamental order,
        at unit multiplier) on the mode's mass-normalized fundamental at this level,
        ``psi_1 = X_1 / a`` over every DOF of the order [N kg^-1/2]."""
        k = self._k1
        lin = self.condensed(omega, xi)
        psi = self.recovered(lin, x)[k] / amplitude
        forces, _ = self.model.forces(self.forced(omega, 1.0))
        return complex(np.vdot(psi, self._lin.take(forces)[k]))

    # ------------------------------------------------------- the linear modes
    def linear_modes(self, count: int, stuck: bool = True) -> list[LinearMode]:
        """The ``count`` lowest elastic modes of the fundamental's order, the contacts
        stuck (their stick stiffness added) or removed; rigid-body modes (a free damper)
        are left out."""
        lin = self.model.linear
        k = self._k1
        K = np.array(lin.K[k], dtype=complex)
        if stuck:
            n = lin.n_dof
            K[:n, :n] += self.model.stick_stiffness(self.fundamental)
        M = np.array(lin.mass(self.point)[k], dtype=complex)
        C = np.array(lin.C[k], dtype=complex)
        if K.shape[0] > DENSE_EIGEN:
            raise ValueError(f"nonlinear modes: the fundamental's order has {K.shape[0]} "
                             f"DOFs; linear modes are found for at most {DENSE_EIGEN}")
        lam, vecs = sla.eigh(0.5 * (K + K.conj().T), 0.5 * (M + M.conj().T))
        elastic = lam > 1e-10 * max(abs(lam[-1]), 1e-300)
        out = []
        for j in np.flatnonzero(elastic)[:count]:
            phi = vecs[:, j] / np.sqrt(np.real(np.vdot(vecs[:, j], M @ vecs[:, j])))
            out.append(LinearMode(float(np.sqrt(lam[j])), phi,
                                  float(np.real(np.vdot(phi, C @ phi)))))
        return out


@dataclass
class ModalResponse(Response):
    """A backbone as a :class:`~microslip.solve.response.Response`: point i is level i's
    operating point (its natural frequency and self-excitation, no dynamic load). What
    re-solves along a forced branch (peak refinement, solutions at a value) does not
    apply."""

    points: tuple[OperatingPoint, ...] = ()

    def point(self, i: int) -> OperatingPoint:
        return self.points[i]


@dataclass(frozen=True)
class Scales:
    """The nondimensional unknowns of the continuation: y = [x_static / length, psi /
    shape, omega / omega_0, xi / omega_0] with x_dynamic = a psi; rows: the static balance
    by ``static_force``, the dynamic one by a ``dynamic_force``."""

    static: np.ndarray  # (n,) bool: the order-0 coefficients
    length: float  # m
    shape: float  # kg^-1/2
    omega0: float  # rad/s
    static_force: float  # N
    dynamic_force: float  # N per unit modal amplitude (N / (kg^1/2 m))
    ref: int  # the phase-fixed coefficient (a contact DOF's fundamental sine)


@dataclass(frozen=True, eq=False)
class ModeSolver:
    """One nonlinear mode's problem for continuation and Newton: unknowns y (``Scales``),
    parameter log10 a."""

    modal: ModalBalance
    scales: Scales
    settings: Settings = DEFAULT

    @cached_property
    def fun(self):
        return _problem(self.modal, self.scales)

    def physical(self, y: np.ndarray, amplitude: float) -> tuple[np.ndarray, float, float]:
        """(x, omega, xi) of the unknowns y at modal amplitude ``amplitude``."""
        sc, n = self.scales, self.modal.model.n_unknowns
        x = np.where(sc.static, y[:n] * sc.length, y[:n] * sc.shape * amplitude)
        return x, float(y[n] * sc.omega0), float(y[n + 1] * sc.omega0)

    def scaled(self, x: np.ndarray, omega: float, xi: float, amplitude: float) -> np.ndarray:
        """The unknowns y of (x, omega, xi) at modal amplitude ``amplitude``."""
        sc = self.scales
        return np.concatenate([np.where(sc.static, x / sc.length, x / (sc.shape * amplitude)),
                               [omega / sc.omega0, xi / sc.omega0]])

    def level(self, amplitude: float, guess: np.ndarray
              ) -> tuple[np.ndarray, float, float] | None:
        """(x, omega, xi) at ``amplitude`` by Newton from the unknowns ``guess``, or None."""
        r = newton(self.fun, guess, float(np.log10(amplitude)), settings=self.settings)
        return self.physical(r.x, amplitude) if r.converged else None


def backbone(modal: ModalBalance, start: LinearMode, amplitudes: tuple[float, float], *,
             settings: Settings | None = None,
             progress: Callable[[int, float, int], None] | None = None) -> Backbone:
    """The nonlinear mode continued from the linear mode ``start`` over modal amplitudes
    ``amplitudes`` = (a_start, a_stop) [kg^1/2 m], by pseudo-arclength in log10 a (the
    static unknowns weighted 1 / STATIC_WEIGHT in its metric: see the module)."""
    a0, a1 = amplitudes
    if not (0.0 < a0 < a1 and np.isfinite(a1)):
        raise ValueError(f"nonlinear modes: amplitudes {amplitudes}: expected 0 < start < "
                         "stop")
    model = modal.model
    h = model.harmonics
    nd, n = model.dofs.size, model.n_unknowns
    psi_c = start.shape[model.dofs]
    psi_c = psi_c * np.exp(-1j * np.angle(psi_c[np.argmax(np.abs(psi_c))]))  # phase 0 there
    x_psi = h.from_complex({modal.fundamental: psi_c}, (nd,)).ravel()
    static = np.tile(h.static_mask, nd) if h.has_static else np.zeros(n, dtype=bool)
    # the static order of the linear response, contacts stuck, without dynamic loads
    x_static = model.linear_guess(modal.forced(start.omega, 0.0), stuck=True) * static
    sc = _scales(modal, start, x_psi, x_static, static)
    y0 = np.concatenate([np.where(static, x_static / sc.length, x_psi / sc.shape),
                         [1.0 * start.omega / sc.omega0, start.xi / sc.omega0]])
    settings = settings or Settings(step=0.02, max_step=0.1)
    solver = ModeSolver(modal, sc, settings)
    xs = np.append(np.where(static, STATIC_WEIGHT, 1.0), [1.0, 1.0])
    branch = arclength(solver.fun, y0, np.log10(a0), np.log10(a1), parameter="log10 amplitude",
                       x_scale=xs, settings=settings, progress=progress)
    lam = np.asarray(branch.values, dtype=float)
    ys = np.asarray(branch.x, dtype=float).reshape(-1, n + 2)
    a = 10.0 ** lam
    xs = np.where(static, ys[:, :n] * sc.length, ys[:, :n] * sc.shape * a[:, None])
    return Backbone(a, ys[:, n] * sc.omega0, ys[:, n + 1] * sc.omega0, xs, branch, solver)


def _scales(modal: ModalBalance, start: LinearMode, x_psi: np.ndarray, x_static: np.ndarray,
            static: np.ndarray) -> Scales:
    """Scales that make every unknown and every row of the continuation about 1."""
    model = modal.model
    h = model.harmonics
    shape = float(np.max(np.abs(x_psi))) or 1.0
    lin = modal.condensed(start.omega, start.xi)
    S0 = modal.condensed(1e-3 * start.omega, 0.0)  # the (nearly) static stiffness
    X = np.array([h.to_complex(x_psi.reshape(model.dofs.size, h.n_coeffs))[o]
                  for o in h.orders])
    dynamic_force = float(np.max(np.abs(S0.S_product(X)))) or 1.0
    static_force = float(np.max(np.abs(lin.F[h.orders.index(0)]))) if h.has_static else 0.0
    length = float(np.max(np.abs(x_static))) if static.any() else 0.0
    i1 = h.dynamic_orders.index(modal.fundamental)
    c1 = x_psi.reshape(model.dofs.size, h.n_coeffs)[:, [h.cos_index[i1], h.sin_index[i1]]]
    ref = int(np.argmax(np.hypot(c1[:, 0], c1[:, 1])))  # the largest fundamental: phase 0
    sin1 = h.sin_index[i1]
    return Scales(static, length or shape * 1e-6, shape, start.omega,
                   static_force or dynamic_force * shape * 1e-6, dynamic_force,
                   ref * h.n_coeffs + sin1)


def _problem(modal: ModalBalance, sc: Scales):
    """The continuation's problem: y -> (rows, d rows / dy, d rows / d log10 a)."""
    model = modal.model
    n = model.n_unknowns
    h = model.harmonics
    dynamic = ~sc.static
    k1 = modal.fundamental
    structured = model.structured

    def fun(y: np.ndarray, lam: float, jacobian: bool = True):
        a = 10.0 ** lam
        col = np.where(sc.static, sc.length, a * sc.shape)  # dx / dy
        row = np.where(sc.static, 1.0 / sc.static_force, 1.0 / (a * sc.dynamic_force))
        x = y[:n] * col
        omega, xi = y[n] * sc.omega0, y[n + 1] * sc.omega0
        R, J, R_w, R_xi, d_xi, lin = modal.balance(x, omega, xi, jacobian, structured)
        psi = modal.fundamental_of(x) / a
        q, g, q_w, q_xi = modal.modal_mass(lin, psi, d_xi)
        out = np.concatenate([row * R, [q - 1.0, y[sc.ref]]])
        if not jacobian:
            return out, None, None
        R_lam = np.zeros(n + 2)
        x_dyn = np.where(dynamic, x, 0.0)
        J_x = J.matvec(x_dyn) if structured else J @ x_dyn
        R_lam[:n] = LN10 * (row * J_x - np.where(dynamic, row * R, 0.0))
        # the borders: columns d/domega, d/dxi; rows q(psi) (psi = fundamental of y's
        # dynamic part x shape) and the phase
        cols = np.column_stack([row * R_w, row * R_xi]) * sc.omega0
        rows = np.zeros((2, n))
        rows[0] = 2.0 * h.from_complex({k1: g}, (model.dofs.size,)).ravel() * sc.shape \
            * dynamic
        rows[1, sc.ref] = 1.0
        corner = np.array([[q_w, q_xi], [0.0, 0.0]]) * sc.omega0
        if structured:
            return out, BorderedJacobian(J, row, col, cols, rows, corner), R_lam
        Jy = np.empty((n + 2, n + 2))
        J *= row[:, None]  # (the residual's own array: scaled in place)
        J *= col[None, :]
        Jy[:n, :n], Jy[:n, n:], Jy[n:, :n], Jy[n:, n:] = J, cols, rows, corner
        return out, Jy, R_lam

    return fun
