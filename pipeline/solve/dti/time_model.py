"""The time model of a lumped case: M, C, K, the contacts packed for the kernel, the two load
steps of the reference text's Fig. 13 and the state a march starts from (see the package)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from microslip.laws.coulomb import ContactElements
from microslip.laws.states import SAMPLE_OPEN, SAMPLE_STICK


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


def checked_positive(name: str, value, *, allow_zero: bool = False) -> float:
    x = float(value)
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        allowed = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"dti: '{name}' = {value!r} is not allowed; must be finite and {allowed}")
    return x


def checked_count(name: str, value, minimum: int) -> int:
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
    :class:`microslip.solve.hbm.Contact`.
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
        """The time-domain twin of a lumped :class:`microslip.solve.hbm.HarmonicBalance`
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
        n = checked_count("n_dof", n_dof, 1)
        return cls(
            _vector("static", static, n),
            _vector("harmonic", harmonic, n, complex),
            checked_positive("ramp_time", ramp_time, allow_zero=True),
            checked_positive("settle_time", settle_time, allow_zero=True),
            checked_count("ramp_periods", ramp_periods, 0),
        )

    @classmethod
    def from_excitation(cls, excitation, n_dof: int, **steps) -> LoadSteps:
        """From a :class:`microslip.solve.linear.Excitation` with orders 0 and 1 only."""
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
