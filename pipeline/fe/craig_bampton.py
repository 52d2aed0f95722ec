"""Craig-Bampton reduction per body and nodal diameter (Firrone & Zucca 5.1.3, eqs. 37-44),
(``modal`` holds modal superposition, eqs. 33-36, the alternative).

Reduced coordinates q = [master DOFs ; fixed-interface modal amplitudes]. Master DOFs are the
global Cartesian x, y, z displacements of the master nodes, node-major: coordinate 3 i + d is
direction d of ``master_nodes[i]``. With K_h, M_h the sector matrices (``cyclic.SectorModel``)
partitioned into masters m and slaves s:

    u_s = Psi u_m + Phi_s eta,   Psi = -K_ss^-1 K_sm (static modes; eq. 39 as it should read),
    K_ss Phi_s = M_ss Phi_s diag(lambda),  Phi_s^H M_ss Phi_s = I (fixed-interface modes),
    k = T^H K_h T,  m = T^H M_h T  (eq. 44), evaluated blockwise without forming T:
    k = [[K_mm + K_ms Psi, 0], [0, diag(lambda)]],
    m = [[M_mm + M_ms Psi + Psi^H (M_sm + M_ss Psi), (M_ms + Psi^H M_ss) Phi_s], [.., I]].

Fixed-interface modes: by default every one below CUTOFF (4) x the 10th fixed-interface
frequency (or x a given f_max), which keeps the first ten frequencies per ND within 0.1 % (see
CUTOFF); an explicit count as the alternative.

For 0 < h < Ns/2 all of these are complex Hermitian. One factorization of K_ss serves the static
modes and the shift-invert eigen-solve. A free-free body (the damper) needs no special
treatment: with every contact DOF a master, K_ss is non-singular and the rigid-body motion is
carried by the static modes, so k has exactly six zero eigenvalues.

Loads: FE load vectors f on the body DOFs go through the same basis, exactly as the matrices:
the cyclic expansion first (f_free = P_h^H f), then q-space T^H f_free = [f_m + Psi^H f_s ;
Phi_s^H f_s]. The static modes make this exact for static reactions on clamped masters and for
any rigid-body motion of the masters. ``reduce_body`` stores the centrifugal load
(``fem.centrifugal_load``, per unit Omega^2) under the name "centrifugal" in the model of ND 0
of a cyclic body (the load is axisymmetric: it has no component on any other ND) and in the
model of a body without cyclic symmetry.

The recovery matrix is kept only on the requested nodes.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from . import cyclic, eigen, linalg
from .fem import Damping, IntArray, MeshLike
from .reduced_model import CUTOFF, DEFAULT_MODES, INTEREST, ReducedModel, reduction_key

#: Convergence tolerance of the fixed-interface modes (shift-invert residual, ARPACK's measure).
#: CB is a Galerkin projection whatever the vectors (the master/mode coupling of k vanishes for
#: any Phi, and Phi^H K Phi is made diagonal by a final Rayleigh-Ritz), so the modes only need to
#: span the low subspace well: at 1e-6 the Ritz frequencies differ from those at 1e-10 by
#: 1e-10 relative (150k-DOF blisk, 30 modes) and the solver needs 15 block solves instead of 20.
EIGEN_TOL = 1e-6
#: Master columns solved per block (bounds the dense right-hand-side memory).
_BLOCK = 512



def _check_nodes(nodes: Sequence[int] | IntArray, what: str) -> IntArray:
    arr = np.asarray(nodes, dtype=np.int64).ravel()
    if len(np.unique(arr)) != len(arr):
        raise ValueError(f"{what}: node indices must be distinct")
    return arr


def _check_selection(n_modes: int | str, cutoff: float, f_max: float | None,
                     available: int) -> None:
    if isinstance(n_modes, str):
        if n_modes != "auto":
            raise ValueError(f"n_modes={n_modes!r}: an integer or 'auto' (cut-off selection)")
        if not (np.isfinite(cutoff) and cutoff >= 1.0):
            raise ValueError(f"cutoff={cutoff!r}: the cut-off multiplier must be >= 1")
        if f_max is not None and not (np.isfinite(f_max) and f_max > 0.0):
            raise ValueError(f"f_max={f_max!r}: must be a positive frequency [Hz] or None")
        return
    check_modes(n_modes, available, "slave")


def check_modes(n_modes: int, available: int, what: str) -> None:
    if not (isinstance(n_modes, int | np.integer) and 0 <= n_modes <= available):
        raise ValueError(
            f"n_modes={n_modes!r}: must be an integer in 0..{available} "
            f"(the {what} space has {available} DOFs)"
        )


def check_loads(model: cyclic.SectorModel, loads: Mapping[str, NDArray] | None
                 ) -> dict[str, NDArray]:
    """The FE load vectors, each (N,) on the body DOFs, finite; ValueError otherwise."""
    out = {}
    for name, f in (loads or {}).items():
        if not (isinstance(name, str) and name):
            raise ValueError(f"loads: names must be non-empty strings, got {name!r}")
        f = np.asarray(f)
        if f.shape != (model.body.n_dofs,) or not np.issubdtype(f.dtype, np.number):
            raise ValueError(f"loads[{name!r}]: shape {f.shape}, expected ({model.body.n_dofs},)"
                             f" (one entry per DOF of body {model.body.body!r})")
        if not np.all(np.isfinite(f)):
            raise ValueError(f"loads[{name!r}]: must be finite")
        out[name] = f
    return out


def free_loads(model: cyclic.SectorModel, loads: Mapping[str, NDArray]) -> dict[str, NDArray]:
    """Loads on the free coordinates: P_h^H f (clamped DOFs drop out; a right-face entry goes to
    its left-face image, rotated back and phase-shifted as the DOFs are)."""
    PH = model.expansion.conj().T.tocsr()
    return {name: PH @ f for name, f in loads.items()}


def recovery_rows(model: cyclic.SectorModel, nodes: IntArray) -> sp.csr_matrix:
    """(3p, n_f) rows of the expansion P_h for the x, y, z DOFs of ``nodes``."""
    dofs = model.body.dofs_of_nodes(nodes, "recovery nodes").ravel()
    return model.expansion[dofs]


@dataclass(frozen=True)
class AveragedMasters:
    """Masters that are weighted averages of body nodes (``geometry.mesh.Mesh.averages``:
    contact points standing for patches of a finer surface mesh).

    points: (p,) their indices; rows, nodes, weights: (a,) the averaging, u(points[rows[k]])
    gets weights[k] u(nodes[k]); xyz: (p, 3) their positions [m].
    """

    points: IntArray
    rows: IntArray
    nodes: IntArray
    weights: NDArray[np.float64]
    xyz: NDArray[np.float64]

    def among(self, masters: IntArray) -> AveragedMasters | None:
        """Those of the averaged points that are in ``masters`` (None: none is)."""
        keep = np.isin(self.points, masters)
        if keep.all():
            return self
        if not keep.any():
            return None
        new = np.cumsum(keep) - 1
        rows = keep[self.rows]
        return AveragedMasters(self.points[keep], new[self.rows[rows]], self.nodes[rows],
                               self.weights[rows], self.xyz[keep])

    @property
    def digest(self) -> str:
        h = hashlib.sha256()
        for a in (self.points, self.rows, self.nodes, self.weights):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()


def averaged_masters(mesh: MeshLike, masters: IntArray) -> AveragedMasters | None:
    """The averaged points among ``masters`` (None: every master is a node)."""
    averages = getattr(mesh, "averages", None)
    if averages is None or not len(averages):
        return None
    points = np.intersect1d(masters, mesh.averaged_points)
    if not len(points):
        return None
    rows, nodes, weights = mesh.averaging(points)
    return AveragedMasters(points, rows, nodes, weights, mesh.points[points])


def _averaging(model: cyclic.SectorModel, averaged: AveragedMasters, order: IntArray
               ) -> sp.csr_matrix:
    """(3p, n_f) W: row 3 i + d is direction d of averaged point ``order[i]`` as a
    combination of the free coordinates (through the cyclic expansion: a node on the
    face that follows the other enters by its image there)."""
    where = np.empty(len(averaged.points), np.int64)
    where[np.searchsorted(averaged.points, order)] = np.arange(len(order))
    dofs = model.body.dofs_of_nodes(averaged.nodes, "averaged nodes")  # (a, 3)
    rows = 3 * where[averaged.rows][:, None] + np.arange(3)
    W = sp.csr_matrix((np.repeat(averaged.weights, 3), (rows.ravel(), dofs.ravel())),
                      shape=(3 * len(order), model.body.n_dofs))
    return (W @ model.expansion).tocsr()


def _master_block(A_mm: NDArray, A_sm: sp.spmatrix, A_ss: sp.spmatrix, Psi: NDArray,
                  cols: IntArray) -> NDArray:
    """[E; Psi]^H A [E; Psi] (c, c) of a Hermitian A partitioned into masters m and slaves
    s: E (n_m, c) puts the master nodes' coordinates at ``cols`` of the c master
    coordinates, Psi (n_s, c) the static modes. Blockwise, so that only Psi and one block
    are held."""
    c = Psi.shape[1]
    X = A_sm.conj().T @ Psi  # (n_m, c)
    out = np.zeros((c, c), dtype=np.result_type(Psi.dtype, A_mm.dtype))
    out[np.ix_(cols, cols)] = A_mm
    out[cols] += X
    out[:, cols] += X.conj().T
    for j in range(0, c, _BLOCK):
        block = slice(j, min(j + _BLOCK, c))
        W = linalg.spmm(A_ss, Psi[:, block])
        out[:, block] += (W.conj().T @ Psi).conj().T  # Psi^H W without copying Psi^H
    return 0.5 * (out + out.conj().T)


def craig_bampton(
    model: cyclic.SectorModel,
    master_nodes: Sequence[int] | IntArray,
    n_modes: int | str = DEFAULT_MODES,
    recovery_nodes: Sequence[int] | IntArray = (),
    patches: Mapping[str, Sequence[int] | IntArray] | None = None,
    damping: Damping | None = None,
    backend: str | None = None,
    timings: dict | None = None,
    cutoff: float = CUTOFF,
    f_max: float | None = None,
    eigen_method: str = "block",
    loads: Mapping[str, NDArray] | None = None,
    averaged: AveragedMasters | None = None,
    region_dofs: Sequence[int] | IntArray = (),
) -> ReducedModel:
    """Craig-Bampton reduction of a sector model (one body, one ND).

    master_nodes: (n_m,) global vertex indices; every contact node plus the excitation and
        response nodes. The master list keeps the given order.
    n_modes: "auto" (default): every fixed-interface mode below ``cutoff`` x f_ref, with f_ref
        = ``f_max`` [Hz] (the highest frequency of interest) if given, else the INTEREST-th
        (10th) fixed-interface frequency; the default CUTOFF meets 0.1 % on the first ten
        frequencies (see CUTOFF). An integer: exactly that many (0 <= n_modes <= slave DOFs).
    recovery_nodes: nodes on which the recovery matrix is kept (pictures, outputs).
    patches: contact-patch name -> node indices (must be masters), stored for the HB stage.
    timings: if a dict is given, filled with the step times [s].
    eigen_method: "block" (block shift-invert Lanczos) or "arpack" (integer n_modes only);
        see ``eigen.lowest_modes``.
    loads: name -> (N,) FE load vector on the body DOFs (e.g. ``fem.centrifugal_load``),
        projected as T^H P_h^H f = [f_m + Psi^H f_s ; Phi_s^H f_s] into ``ReducedModel.loads``.
    averaged: the masters that are averages of body nodes (``averaged_masters``): their
        coordinates are W u, the static modes the least-energy fields with W u = e_j (and
        W u = 0 for the nodes' columns), the fixed-interface modes those with W u = 0
        (``linalg.ConstrainedFactor``); a force on them reaches the nodes as W^H f.
    region_dofs: (n_b,) body DOFs of a region whose stiffness may deviate (a mistuned
        blade's): the basis rows there are kept (``ReducedModel.region``).
    All inputs are checked before any factorization.
    """
    part = _partition(model, master_nodes, n_modes, recovery_nodes, patches, backend, cutoff,
                      f_max, eigen_method, averaged)
    loads = check_loads(model, loads)
    region_dofs = _check_region(model, region_dofs)
    t0 = time.perf_counter()
    factor, W_m = _slave_factor(model, part)
    t1 = time.perf_counter()
    Psi = _static_modes(part, factor, W_m)
    t2 = time.perf_counter()
    lam, Phi = _fixed_interface_modes(part, factor, n_modes, cutoff, f_max, eigen_method)
    factor.free()
    t3 = time.perf_counter()
    k_red, m_red = _reduced_matrices(part, Psi, lam, Phi)
    R = _recovery(model, part, Psi, Phi)
    reduced_loads = _reduced_loads(model, part, Psi, Phi, loads)
    region = _basis_rows(part, model.expansion[region_dofs], Psi, Phi)
    t4 = time.perf_counter()
    if timings is not None:
        timings.update(factorize=t1 - t0, static_modes=t2 - t1, eigen=t3 - t2,
                       projection=t4 - t3, backend=part.backend)
    averaged = part.averaged
    return ReducedModel(
        body=model.body.body,
        method="craig-bampton",
        stiffness=k_red,
        mass=m_red,
        master_nodes=part.masters,
        master_coordinates=_master_xyz(model, part.masters, part.is_averaged, averaged),
        n_modes=int(len(lam)),
        mode_frequencies=np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi),
        recovery_nodes=part.recovery,
        recovery=R,
        nodal_diameter=model.nodal_diameter,
        sectors=model.sectors,
        patches=part.patches,
        damping_spec=damping,
        key=reduction_key(model, "craig-bampton", part.masters, n_modes, part.recovery,
                          part.patches, cutoff, f_max, loads,
                          averaged.digest if averaged is not None else "", region_dofs),
        loads=reduced_loads,
        region_dofs=region_dofs,
        region=region,
    )


@dataclass(frozen=True)
class _Partition:
    """A sector's free coordinates split into masters m and slaves s (checked inputs).

    masters: (n_m,) the master points in the given order; is_averaged (n_m,) which are
    averaged points; m_idx (3 n_node,) the free coordinates of the node masters, s_idx the
    slaves'; cols (3 n_node,) where the node masters sit among the 3 n_m master
    coordinates; n_s_free: the slave space less the averages held; K_ss, K_sm, K_mm, M_..:
    the blocks [N/m], [kg]."""

    masters: IntArray
    recovery: IntArray
    patches: dict[str, IntArray]
    averaged: AveragedMasters | None
    is_averaged: NDArray[np.bool_]
    m_idx: IntArray
    s_idx: IntArray
    cols: IntArray
    n_s_free: int
    backend: str
    K_ss: sp.csr_matrix
    K_sm: sp.csc_matrix
    K_mm: NDArray
    M_ss: sp.csr_matrix
    M_sm: sp.csc_matrix
    M_mm: NDArray
    dtype: np.dtype

    @property
    def n_c(self) -> int:
        """Master coordinates: 3 per master point."""
        return 3 * len(self.masters)


def _partition(model: cyclic.SectorModel, master_nodes, n_modes, recovery_nodes, patches,
               backend, cutoff, f_max, eigen_method, averaged) -> _Partition:
    """The checked inputs of ``craig_bampton`` and the matrix blocks (ValueError before any
    factorization)."""
    masters = _check_nodes(master_nodes, "master_nodes")
    recovery = np.unique(np.asarray(recovery_nodes, dtype=np.int64))
    if len(masters) == 0:
        raise ValueError("master_nodes: at least one master node is required for Craig-Bampton")
    if averaged is not None:
        averaged = averaged.among(masters)
    is_averaged = (np.isin(masters, averaged.points) if averaged is not None
                   else np.zeros(len(masters), bool))
    m_idx = model.free_index(masters[~is_averaged], "master_nodes").ravel()
    cols = (3 * np.flatnonzero(~is_averaged)[:, None] + np.arange(3)).ravel()
    n_f = model.n_free
    n_s_free = n_f - len(m_idx) - 3 * int(is_averaged.sum())
    _check_selection(n_modes, cutoff, f_max, n_s_free)
    if eigen_method not in ("block", "arpack") or (eigen_method == "arpack"
                                                   and isinstance(n_modes, str)):
        raise ValueError(f"eigen_method={eigen_method!r}: 'block', or 'arpack' with an integer "
                         "n_modes")
    if len(recovery):
        model.body.local_nodes(recovery, "recovery_nodes")
    patches = {k: _check_nodes(v, f"patches[{k!r}]") for k, v in (patches or {}).items()}
    for name, nodes in patches.items():
        if not np.isin(nodes, masters).all():
            raise ValueError(f"patches[{name!r}]: every patch node must be a master node")
    backend = linalg.check_backend(backend, model.n_free)
    is_master = np.zeros(n_f, dtype=bool)
    is_master[m_idx] = True
    s_idx = np.flatnonzero(~is_master)
    K, M = model.stiffness, model.mass
    K_s, M_s = K[s_idx], M[s_idx]
    return _Partition(
        masters, recovery, patches, averaged, is_averaged, m_idx, s_idx, cols, n_s_free,
        backend, K_s[:, s_idx].tocsr(), K_s[:, m_idx].tocsc(), K[m_idx][:, m_idx].toarray(),
        M_s[:, s_idx].tocsr(), M_s[:, m_idx].tocsc(), M[m_idx][:, m_idx].toarray(),
        np.result_type(K.dtype, M.dtype))


def _slave_factor(model: cyclic.SectorModel, part: _Partition):
    """(factor, W_m): the factorization of K_ss (with the averaged points' W u = 0 held
    where there are some: ``linalg.ConstrainedFactor``) that serves the static modes and the
    eigen-solve, and the averaging's master columns (None: every master a node)."""
    if part.is_averaged.any():
        W = _averaging(model, part.averaged, part.masters[part.is_averaged])
        return linalg.ConstrainedFactor(part.K_ss, W[:, part.s_idx], part.backend), \
            W[:, part.m_idx].tocsc()
    return linalg.factorize(part.K_ss, backend=part.backend, positive_definite=True), None


def _static_modes(part: _Partition, factor, W_m: sp.csc_matrix | None) -> NDArray:
    """(n_s, n_c) Psi: the slaves' static response to each master coordinate (K_ss Psi =
    -K_sm; averaged points: the least-energy fields with W u = e_j), in blocks of _BLOCK
    columns (the dense right-hand sides' memory); W_m: the averaging's master columns."""
    n_s, n_m = len(part.s_idx), len(part.m_idx)
    Psi = np.empty((n_s, part.n_c), dtype=part.dtype, order="F")
    for j in range(0, n_m, _BLOCK):
        block = slice(j, min(j + _BLOCK, n_m))
        if W_m is not None:  # u_m = e_j, W u = 0
            Psi[:, part.cols[block]] = factor.solve((-part.K_sm[:, block]).toarray(),
                                                    (-W_m[:, block]).toarray())
        else:
            Psi[:, part.cols[block]] = factor.solve((-part.K_sm[:, block]).toarray())
    if W_m is not None:  # u_m = 0, W u = e_j
        tied = (3 * np.flatnonzero(part.is_averaged)[:, None] + np.arange(3)).ravel()
        Psi[:, tied] = factor.solve(np.zeros((n_s, len(tied)), part.dtype),
                                    np.eye(len(tied), dtype=part.dtype))
    return Psi


def _fixed_interface_modes(part: _Partition, factor, n_modes: int | str, cutoff: float,
                           f_max: float | None, eigen_method: str) -> tuple[NDArray, NDArray]:
    """(lam (k,) [rad^2/s^2], Phi (n_s, k)) the fixed-interface modes the selection keeps
    (``n_modes``: a count, or "auto": every one below ``cutoff`` x f_ref)."""
    n_s = len(part.s_idx)
    if n_modes == "auto" and n_s > 0:
        if f_max is None:
            k0 = min(INTEREST, part.n_s_free)
            upper = lambda lam: cutoff**2 * lam[-1]  # noqa: E731
        else:
            k0, upper = 1, (2.0 * np.pi * cutoff * f_max) ** 2
        return eigen.lowest_modes(part.K_ss, part.M_ss, k0, factor=factor, upper=upper,
                                   method=eigen_method, tol=EIGEN_TOL)
    if n_modes != "auto" and n_modes > 0:
        return eigen.lowest_modes(part.K_ss, part.M_ss, int(n_modes), factor=factor,
                                   method=eigen_method, tol=EIGEN_TOL)
    return np.empty(0), np.empty((n_s, 0), dtype=part.dtype)


def _reduced_matrices(part: _Partition, Psi: NDArray, lam: NDArray, Phi: NDArray
                      ) -> tuple[NDArray, NDArray]:
    """(k, m) (r, r), r = n_c + k: eq. 44 blockwise, without forming T."""
    cols, n_c = part.cols, part.n_c
    # Reduced stiffness: the Schur complement (Hermitian part) where every master is a node
    # (K_ss Psi = -K_sm), the whole quadratic form where some are averages (there K_ss Psi
    # = -K_sm - W^H lam); the modal diagonal.
    if part.is_averaged.any():
        K_hat = _master_block(part.K_mm, part.K_sm, part.K_ss, Psi, cols)
    else:
        K_hat = part.K_mm + (part.K_sm.conj().T @ Psi)
        K_hat = 0.5 * (K_hat + K_hat.conj().T)
    M_hat = _master_block(part.M_mm, part.M_sm, part.M_ss, Psi, cols)
    M_SPhi = linalg.spmm(part.M_ss, Phi)
    M_meta = (M_SPhi.conj().T @ Psi).conj().T
    M_meta[cols] += part.M_sm.conj().T @ Phi
    M_eta = Phi.conj().T @ M_SPhi
    M_eta = 0.5 * (M_eta + M_eta.conj().T)
    r = n_c + len(lam)
    k_red = np.zeros((r, r), dtype=part.dtype)
    m_red = np.zeros((r, r), dtype=part.dtype)
    k_red[:n_c, :n_c] = K_hat
    k_red[n_c:, n_c:] = np.diag(lam)
    m_red[:n_c, :n_c] = M_hat
    m_red[:n_c, n_c:] = M_meta
    m_red[n_c:, :n_c] = M_meta.conj().T
    m_red[n_c:, n_c:] = M_eta
    return k_red, m_red


def _recovery(model: cyclic.SectorModel, part: _Partition, Psi: NDArray, Phi: NDArray
              ) -> NDArray:
    """(p, 3, r) the recovery rows: u_body = P u_free, u_free[m] = q_m, u_free[s] = Psi q_m
    + Phi eta."""
    if not len(part.recovery):
        return np.zeros((0, 3, part.n_c + Phi.shape[1]), dtype=part.dtype)
    R = _basis_rows(part, recovery_rows(model, part.recovery), Psi, Phi)
    return R.reshape(len(part.recovery), 3, -1)


def _basis_rows(part: _Partition, rows: sp.spmatrix, Psi: NDArray, Phi: NDArray) -> NDArray:
    """(k, r) the reduction basis' rows of body DOFs: ``rows`` (k, n_f) their rows of the
    expansion P, times T = [masters: I; slaves: Psi, Phi]."""
    n_c = part.n_c
    R = np.zeros((rows.shape[0], n_c + Phi.shape[1]),
                 dtype=np.result_type(part.dtype, rows.dtype))
    if not rows.shape[0]:
        return R
    R[:, part.cols] = rows[:, part.m_idx].toarray()
    Rs = rows[:, part.s_idx]
    R[:, :n_c] += Rs @ Psi
    R[:, n_c:] = Rs @ Phi
    return R


def _check_region(model: cyclic.SectorModel, region_dofs) -> IntArray:
    """The region's body DOFs, sorted and checked (ValueError naming the first bad one)."""
    dofs = np.unique(np.asarray(region_dofs, dtype=np.int64))
    bad = dofs[(dofs < 0) | (dofs >= model.body.n_dofs)]
    if len(bad):
        raise ValueError(f"region_dofs: {int(bad[0])} is not a DOF of body "
                         f"{model.body.body!r} (0..{model.body.n_dofs - 1})")
    return dofs


def _reduced_loads(model: cyclic.SectorModel, part: _Partition, Psi: NDArray, Phi: NDArray,
                   loads: Mapping[str, NDArray]) -> dict[str, NDArray]:
    """name -> (r,) T^H P^H f = [f_m + Psi^H f_s ; Phi^H f_s] (as (Psi^T conj(f_s))^*: no
    copy of Psi^H)."""
    n_c = part.n_c
    r = n_c + Phi.shape[1]
    out = {}
    for name, f in free_loads(model, loads).items():
        f_s = f[part.s_idx].conj()
        red = np.empty(r, dtype=np.result_type(part.dtype, f.dtype))
        red[:n_c] = (Psi.T @ f_s).conj()
        red[part.cols] += f[part.m_idx]
        red[n_c:] = (Phi.T @ f_s).conj()
        out[name] = red
    return out


def _master_xyz(model: cyclic.SectorModel, masters: IntArray, is_averaged: NDArray,
                averaged: AveragedMasters | None) -> NDArray[np.float64]:
    """(n_m, 3) [m] the masters' positions (nodes' and averaged points')."""
    xyz = np.empty((len(masters), 3))
    xyz[~is_averaged] = model.body.points[model.body.local_nodes(masters[~is_averaged])]
    if is_averaged.any():
        xyz[is_averaged] = averaged.xyz[np.searchsorted(averaged.points,
                                                        masters[is_averaged])]
    return xyz
