"""Multi-harmonic balance on the contact DOFs (seed section 2 and appendix).

For each kept harmonic order n the linear part is the dynamic stiffness
``D_n(w) = K_n - (n w)^2 M_n + i n w C_n`` (real, or complex Hermitian from the
cyclic-symmetry stage). DOFs that no contact touches are condensed exactly per
harmonic, ``S_n = D_cc - D_ci D_ii^-1 D_ic``, so the unknowns are the contact
DOFs only and no receptance (``K^-1`` at n = 0) is needed: a free-free damper
held only by its contacts is fine. Every other DOF is recovered afterwards
(seed eq. 9).

Unknowns ``x`` are real, DOF-major: ``x[dof, coeff]`` in the layout of
:class:`~microslip.pipeline.friction.harmonics.Harmonics`. The residual is

    R(x) = S x - F + B^T f(B x)

with ``f`` the contact forces (resisting the relative displacements ``B x``).
Scalar parameters that continuation may follow (``PARAMETERS``):

frequency   w, rad/s
excitation  multiplier of the dynamic (n >= 1) external forces; static loads stay
mass        multiplier s of ``LinearDynamics.mass_part``: ``M(s) = M + (s - 1) M_part``
preload     multiplier of every contact's ``n0`` (``N0`` or ``kn * interference``)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from microslip.pipeline.friction.harmonics import Harmonics
from microslip.pipeline.friction.laws import ContactElements, ContactResponse

PARAMETERS = ("frequency", "excitation", "mass", "preload")
_DENSE_LIMIT = 400_000  # entries of the real kinematic map kept dense


@dataclass(frozen=True)
class OperatingPoint:
    """Values of the scalar parameters at which the balance is solved.

    omega: angular frequency [rad/s]; excitation, mass_multiplier, preload: dimensionless
    multipliers (see ``PARAMETERS``; a continuation parameter name maps to its field).
    """

    omega: float
    excitation: float = 1.0
    mass_multiplier: float = 1.0
    preload: float = 1.0

    def get(self, name: str) -> float:
        return getattr(self, _field(name))

    def set(self, name: str, value: float) -> OperatingPoint:
        return replace(self, **{_field(name): float(value)})


_FIELDS = {"frequency": "omega", "excitation": "excitation", "mass": "mass_multiplier",
           "preload": "preload"}  # continuation parameter -> OperatingPoint field


def _field(name: str) -> str:
    if name not in PARAMETERS:
        raise ValueError(f"hbm: parameter {name!r} is not one of {PARAMETERS}")
    return _FIELDS[name]


def _stack(name: str, value, orders: tuple[int, ...], n: int | None) -> np.ndarray:
    """Per-order matrices -> (n_orders, n, n) complex; a single matrix serves all."""
    if isinstance(value, Mapping):
        missing = [o for o in orders if o not in value]
        if missing:
            raise ValueError(f"hbm: '{name}' has no matrix for harmonic orders {missing}")
        mats = [np.asarray(value[o]) for o in orders]
    else:
        mats = [np.asarray(value)] * len(orders)
    out = np.array(mats, dtype=complex)
    if out.ndim != 3 or out.shape[1] != out.shape[2]:
        raise ValueError(f"hbm: '{name}' must be square matrices, got shape {out.shape[1:]}")
    if n is not None and out.shape[1] != n:
        raise ValueError(f"hbm: '{name}' is {out.shape[1]}x{out.shape[1]}, expected {n}x{n}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"hbm: '{name}' contains NaN or Inf")
    return out


@dataclass(frozen=True, eq=False)
class LinearDynamics:
    """The linear part per harmonic order: K_n, M_n, C_n, (n_dof, n_dof).

    Each argument is one matrix for every order (lumped models) or a mapping
    ``{order: matrix}`` (cyclic symmetry: the matrices of the order's nodal
    diameter). ``mass_part`` is the part of M a mass multiplier scales.
    """

    K: np.ndarray  # (n_orders, n, n) complex
    M: np.ndarray
    C: np.ndarray
    M_part: np.ndarray
    orders: tuple[int, ...]

    @classmethod
    def create(cls, K, M, C=None, *, harmonics: Harmonics, mass_part=None) -> LinearDynamics:
        orders = harmonics.orders
        Ks = _stack("K", K, orders, None)
        n = Ks.shape[1]
        Ms = _stack("M", M, orders, n)
        Cs = _stack("C", np.zeros((n, n)) if C is None else C, orders, n)
        Mp = _stack("mass_part", np.zeros((n, n)) if mass_part is None else mass_part, orders, n)
        for name, mats in (("K", Ks), ("M", Ms), ("C", Cs)):
            asym = np.abs(mats - np.conj(mats.transpose(0, 2, 1))).max()
            if asym > 1e-9 * max(np.abs(mats).max(), 1e-300):
                raise ValueError(f"hbm: '{name}' is not symmetric (Hermitian): max |A - A^H| = "
                                 f"{asym:.3g}")
        if 0 in orders and np.abs(Ks[0].imag).max() > 1e-12 * max(np.abs(Ks[0]).max(), 1e-300):
            raise ValueError("hbm: 'K' of harmonic order 0 must be real (nodal diameter 0)")
        return cls(Ks, Ms, Cs, Mp, orders)

    @property
    def n_dof(self) -> int:
        return self.K.shape[1]

    def mass(self, point: OperatingPoint) -> np.ndarray:
        """(n_orders, n, n) M(s) = M + (s - 1) M_part at the point's mass multiplier s.

        The one mechanism of mass studies (a damper's mass as a multiple of its nominal
        mass): exact for a reduced body, whose basis does not depend on its density.
        """
        if point.mass_multiplier == 1.0:
            return self.M
        return self.M + (point.mass_multiplier - 1.0) * self.M_part

    def dynamic_stiffness(self, point: OperatingPoint) -> np.ndarray:
        """(n_orders, n, n) D_n at the point."""
        nw = np.array(self.orders, dtype=float)[:, None, None] * point.omega
        return self.K - nw**2 * self.mass(point) + 1j * nw * self.C

    def d_dynamic_stiffness(self, point: OperatingPoint, parameter: str) -> np.ndarray | None:
        """dD_n / d parameter, or None where D does not depend on it."""
        n = np.array(self.orders, dtype=float)[:, None, None]
        if parameter == "frequency":
            return -2.0 * n**2 * point.omega * self.mass(point) + 1j * n * self.C
        if parameter == "mass":
            return -((n * point.omega) ** 2) * self.M_part
        return None


@dataclass(frozen=True, eq=False)
class Contact:
    """A named set of contact points and their kinematics.

    kinematics: (P * c, n_dof) real matrix, rows ordered (point, component
    ``[u_1, ..., u_d, (v)]``), giving the relative displacements from the DOFs
    for every harmonic; or ``{order: complex matrix}`` when it differs per
    order (a contact with the neighbouring sector: phase ``exp(i n EO phi)``).
    """

    name: str
    elements: ContactElements
    kinematics: np.ndarray | Mapping[int, np.ndarray]


@dataclass(frozen=True, eq=False)
class Excitation:
    """External forces ``F(t) = Re(sum_n F_n exp(i n w t))``: {order: (n_dof,) complex}."""

    forces: Mapping[int, np.ndarray]

    @classmethod
    def single(cls, n_dof: int, dof: int, amplitude: float, order: int = 1,
               phase: float = 0.0) -> Excitation:
        """``amplitude cos(order w t + phase)`` on one DOF."""
        f = np.zeros(n_dof, dtype=complex)
        f[dof] = amplitude * np.exp(1j * phase)
        return cls({order: f})

    def vector(self, orders: tuple[int, ...], n_dof: int) -> np.ndarray:
        """(n_orders, n_dof) complex forces of the kept orders."""
        F = np.zeros((len(orders), n_dof), dtype=complex)
        for k, o in enumerate(orders):
            if o in self.forces:
                f = np.asarray(self.forces[o], dtype=complex)
                if f.shape != (n_dof,):
                    raise ValueError(
                        f"hbm: excitation of order {o} has shape {f.shape}, expected ({n_dof},)"
                    )
                F[k] = f
        return F


@dataclass(frozen=True)
class Condensed:
    """Linear part condensed on the contact DOFs at one operating point."""

    S: np.ndarray  # (n_orders, nc, nc) complex
    F: np.ndarray  # (n_orders, nc) complex
    Y: np.ndarray | None  # (n_orders, ni, nc): q_i = z - Y q_c
    z: np.ndarray | None  # (n_orders, ni)
    dS: np.ndarray | None
    dF: np.ndarray | None


class HarmonicBalance:
    """The nonlinear algebraic system of one model at given harmonics.

    Build once; evaluate :meth:`residual` for any state and operating point.
    """

    def __init__(
        self,
        linear: LinearDynamics,
        contacts: Sequence[Contact],
        excitation: Excitation,
        harmonics: Harmonics,
        *,
        sub_sample: bool = True,
    ):
        if tuple(linear.orders) != harmonics.orders:
            raise ValueError(
                f"hbm: linear part built for orders {linear.orders}, harmonics are "
                f"{harmonics.orders}"
            )
        self.linear = linear
        self.harmonics = harmonics
        self.sub_sample = bool(sub_sample)
        self.excitation = excitation
        self.contacts = tuple(contacts)
        n = linear.n_dof
        self.F_ext = excitation.vector(harmonics.orders, n)
        names = [c.name for c in self.contacts]
        if len(set(names)) != len(names):
            raise ValueError(f"hbm: contact names must be unique, got {names}")
        used = np.zeros(n, dtype=bool)
        self._B = []
        for c in self.contacts:
            B = self._kinematics(c)
            for mat in B.values():
                used |= np.any(mat != 0, axis=0)
            self._B.append(B)
        self.dofs = np.flatnonzero(used)  # the unknowns: contact DOFs
        self.others = np.flatnonzero(~used)
        self._Breal = [self._real_kinematics(B) for B in self._B]
        self._cache: dict = {}

    # --------------------------------------------------------------- set-up
    def _kinematics(self, c: Contact) -> dict[int, np.ndarray]:
        rows = c.elements.size * c.elements.n_components
        n = self.linear.n_dof
        if isinstance(c.kinematics, Mapping):
            missing = [o for o in self.harmonics.orders if o not in c.kinematics]
            if missing:
                raise ValueError(
                    f"hbm: contact '{c.name}' kinematics lacks harmonic orders {missing}"
                )
            B = {o: np.asarray(c.kinematics[o], dtype=complex) for o in self.harmonics.orders}
        else:
            mat = np.asarray(c.kinematics, dtype=float)
            B = {o: mat for o in self.harmonics.orders}
        for o, mat in B.items():
            if mat.shape != (rows, n):
                raise ValueError(
                    f"hbm: contact '{c.name}' kinematics (order {o}) has shape {mat.shape}, "
                    f"expected (points * components, n_dof) = ({rows}, {n})"
                )
            if not np.all(np.isfinite(mat)):
                raise ValueError(f"hbm: contact '{c.name}' kinematics contains NaN or Inf")
        return B

    def _real_kinematics(self, B: dict[int, np.ndarray]) -> np.ndarray | sp.csr_matrix:
        """Real map x (DOF-major, contact DOFs only) -> g (row-major, coeffs).

        Dense while small (sparse bookkeeping costs more than it saves on the
        lumped models), CSR otherwise."""
        h = self.harmonics
        nc = h.n_coeffs
        blocks = []
        for o, mat in B.items():
            Bc = mat[:, self.dofs]
            Br, Bi = np.real(Bc), np.imag(Bc)
            if o == 0:
                sel = np.zeros((nc, nc))
                sel[0, 0] = 1.0
                blocks.append(sp.kron(Br, sel))
                continue
            k = h.dynamic_orders.index(o)
            ia, ib = h.cos_index[k], h.sin_index[k]
            same = np.zeros((nc, nc))
            same[ia, ia] = same[ib, ib] = 1.0
            cross = np.zeros((nc, nc))
            cross[ia, ib] = 1.0
            cross[ib, ia] = -1.0
            blocks.append(sp.kron(Br, same))
            if np.any(Bi != 0):
                blocks.append(sp.kron(Bi, cross))
        Br = sp.csr_matrix(sum(blocks[1:], blocks[0]))
        return Br.toarray() if Br.shape[0] * Br.shape[1] <= _DENSE_LIMIT else Br

    @property
    def n_unknowns(self) -> int:
        return self.dofs.size * self.harmonics.n_coeffs

    # ---------------------------------------------------------- linear part
    def condensed(self, point: OperatingPoint, parameter: str | None = None) -> Condensed:
        """Exact condensation on the contact DOFs (cached per point)."""
        key = (point, parameter)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        D = self.linear.dynamic_stiffness(point)
        dD = self.linear.d_dynamic_stiffness(point, parameter) if parameter else None
        dyn = np.array([o > 0 for o in self.harmonics.orders])[:, None]
        F = self.F_ext * np.where(dyn, point.excitation, 1.0)
        dF = None
        if parameter == "excitation":
            dF = self.F_ext * dyn
        elif parameter is not None:
            dF = np.zeros_like(F)
        out = _condense(D, F, self.dofs, self.others, dD, dF)
        if len(self._cache) > 16:
            self._cache.clear()
        self._cache[key] = out
        return out

    def _real_condensed(self, point: OperatingPoint, parameter: str | None):
        """(S, F, dS, dF) of the condensed linear part in the real DOF-major layout."""
        key = ("real", point, parameter)
        hit = self._cache.get(key)
        if hit is None:
            lin = self.condensed(point, parameter)
            h = self.harmonics
            hit = (
                h.real_matrix(lin.S),
                h.real_vector(lin.F).ravel(),
                None if lin.dS is None else h.real_matrix(lin.dS),
                None if lin.dF is None else h.real_vector(lin.dF).ravel(),
            )
            self._cache[key] = hit
        return hit

    # ------------------------------------------------------------- residual
    def residual(
        self,
        x: np.ndarray,
        point: OperatingPoint,
        parameter: str | None = None,
        jacobian: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """R(x), dR/dx and dR/d(parameter) at ``point``.

        x: (n_unknowns,) real, DOF-major over :attr:`dofs`. Returns R (n,),
        J (n, n) or None, dR (n,) or None (if ``parameter`` is None).
        """
        S, F, dS, dF = self._real_condensed(point, parameter)
        R = S @ x - F
        J = S.copy() if jacobian else None
        dR = None
        if parameter is not None:
            dR = (dS @ x if dS is not None else np.zeros_like(x)) - dF
        for c, Br in zip(self.contacts, self._Breal):
            el = c.elements.with_n0(c.elements.n0 * point.preload) if point.preload != 1 else (
                c.elements
            )
            g = (Br @ x).reshape(el.size, el.n_components, -1)
            r = el.evaluate(g, self.harmonics, jacobian=jacobian or parameter == "preload",
                            corrections=self.sub_sample)
            R += Br.T @ r.forces.ravel()
            if jacobian:
                J += _sandwich(Br, r.jacobian)
            if parameter == "preload":
                dR += Br.T @ (r.d_n0 * c.elements.n0[:, None, None]).ravel()
        return R, J, dR

    # ------------------------------------------------------- post-processing
    def relative_displacements(self, x: np.ndarray) -> list[np.ndarray]:
        """Per contact: (P, c, ncoeff) relative displacement coefficients."""
        return [
            (Br @ x).reshape(c.elements.size, c.elements.n_components, -1)
            for c, Br in zip(self.contacts, self._Breal)
        ]

    def contact_response(
        self, x: np.ndarray, point: OperatingPoint, histories: bool = False
    ) -> list[ContactResponse]:
        """Per contact: forces, states, dissipation (and time histories)."""
        out = []
        for c, g in zip(self.contacts, self.relative_displacements(x)):
            el = c.elements.with_n0(c.elements.n0 * point.preload)
            out.append(el.evaluate(g, self.harmonics, jacobian=False, histories=histories,
                                   corrections=self.sub_sample))
        return out

    def recover(self, x: np.ndarray, point: OperatingPoint) -> np.ndarray:
        """(n_dof, ncoeff) coefficients of every DOF (seed eq. 9)."""
        h = self.harmonics
        lin = self.condensed(point)
        xc = x.reshape(self.dofs.size, h.n_coeffs)
        Q = np.zeros((self.linear.n_dof, h.n_coeffs))
        Q[self.dofs] = xc
        if self.others.size:
            Xc = h.to_complex(xc)
            Xi = {o: lin.z[k] - lin.Y[k] @ Xc[o] for k, o in enumerate(h.orders)}
            Q[self.others] = h.from_complex(Xi, (self.others.size,))
        return Q

    def energy_balance(self, x: np.ndarray, point: OperatingPoint) -> dict[str, float]:
        """Work per cycle, J: excitation, viscous, contacts (friction + normal)."""
        h = self.harmonics
        Q = self.recover(x, point)
        dyn = np.array([o > 0 for o in h.orders])[:, None]
        F = self.F_ext * np.where(dyn, point.excitation, 1.0)
        Fr = h.from_complex({o: F[k] for k, o in enumerate(h.orders)}, (self.linear.n_dof,))
        w_ext = float(h.work(Fr, Q).sum())
        Qc = h.to_complex(Q)
        w_visc = 0.0
        for k, o in enumerate(h.orders):
            if o > 0:
                w_visc += np.pi * point.omega * o**2 * float(np.real(
                    np.conj(Qc[o]) @ self.linear.C[k] @ Qc[o]))
        resp = self.contact_response(x, point)
        w_fric = float(sum(r.dissipation.sum() for r in resp))
        w_norm = float(sum(r.normal_work.sum() for r in resp))
        return {"excitation": w_ext, "viscous": w_visc, "friction": w_fric, "normal": w_norm}

    def linear_guess(self, point: OperatingPoint, stuck: bool = False) -> np.ndarray:
        """Linear response, DOF-major: contacts removed (free system) or, with
        ``stuck``, replaced by their stick stiffness (kt, and kn for the variable
        laws). A singular free system (a body held only by its contacts) falls
        back to the stuck one."""
        lin = self.condensed(point)
        S = self.harmonics.real_matrix(lin.S)
        F = self.harmonics.real_vector(lin.F).ravel()
        if S.size == 0:
            return np.zeros(0)
        if not stuck:
            with np.errstate(all="ignore"):
                if np.linalg.cond(S) < 1e12:
                    return np.linalg.solve(S, F)
        for c, Br in zip(self.contacts, self._Breal):
            S = S + _sandwich(Br, _stick_blocks(c.elements, self.harmonics.n_coeffs))
        return np.linalg.lstsq(S, F, rcond=None)[0]


def _stick_blocks(el: ContactElements, nc: int) -> np.ndarray:
    """(P, c, nc, c, nc) stiffness of stuck contacts: kt per direction, kn normal."""
    blocks = np.zeros((el.size, el.n_components, nc, el.n_components, nc))
    eye = np.eye(nc)
    for j in range(el.dim):
        blocks[:, j, :, j, :] = el.kt[:, j, None, None] * eye
    if el.variable_normal:
        blocks[:, -1, :, -1, :] = el.kn[:, None, None] * eye
    return blocks


def _sandwich(Br: np.ndarray | sp.csr_matrix, blocks: np.ndarray) -> np.ndarray:
    """B^T diag(blocks) B for per-point blocks (P, c, nc, c, nc) -> dense (n, n)."""
    P = blocks.shape[0]
    m = blocks.shape[1] * blocks.shape[2]
    if isinstance(Br, np.ndarray):
        B3 = Br.reshape(P, m, -1)
        JB = np.matmul(blocks.reshape(P, m, m), B3)
        return Br.T @ JB.reshape(P * m, -1)
    Jc = sp.bsr_matrix(
        (blocks.reshape(P, m, m), np.arange(P), np.arange(P + 1)), shape=(P * m, P * m)
    )
    return np.asarray((Br.T @ (Jc @ Br)).todense())


def _condense(D, F, c, i, dD=None, dF=None) -> Condensed:
    """Exact per-order condensation of D q = F onto DOFs c (others i).

    D: (n_orders, n, n); F: (n_orders, n); dD, dF: their derivatives or None."""
    Dcc = D[:, c][:, :, c]
    if i.size == 0:
        return Condensed(Dcc, F[:, c], None, None,
                         None if dD is None else dD[:, c][:, :, c],
                         None if dF is None else dF[:, c])
    Dci, Dic, Dii = D[:, c][:, :, i], D[:, i][:, :, c], D[:, i][:, :, i]
    rhs = np.concatenate([Dic, F[:, i, None]], axis=2)
    sol = np.linalg.solve(Dii, rhs)
    Y, z = sol[:, :, :-1], sol[:, :, -1]
    S = Dcc - Dci @ Y
    Fe = F[:, c] - np.einsum("kab,kb->ka", Dci, z)
    dS = dFe = None
    if dD is not None or dF is not None:
        # L = Dci Dii^-1 (left factor), dS = dDcc - dDci Y - L dDic + L dDii Y
        L = np.linalg.solve(np.transpose(Dii, (0, 2, 1)), np.transpose(Dci, (0, 2, 1)))
        L = np.transpose(L, (0, 2, 1))
        dS = np.zeros_like(S)
        dFe = np.zeros_like(Fe) if dF is None else dF[:, c] - np.einsum("kab,kb->ka", L, dF[:, i])
        if dD is not None:
            dcc, dci = dD[:, c][:, :, c], dD[:, c][:, :, i]
            dic, dii = dD[:, i][:, :, c], dD[:, i][:, :, i]
            dS = dcc - dci @ Y - L @ dic + L @ dii @ Y
            # dF_eff = -(dDci - L dDii) z
            dFe = dFe - np.einsum("kab,kb->ka", dci - L @ dii, z)
    return Condensed(S, Fe, Y, z, dS, dFe)
