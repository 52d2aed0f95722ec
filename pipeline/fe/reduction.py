"""Craig-Bampton reduction per body and nodal diameter (Firrone & Zucca 5.1.3, eqs. 37-44),
and modal superposition (eqs. 33-36) as the alternative.

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

The recovery matrix is kept only on the requested nodes. Models are stored in HDF5 (never
pickle) and reused when the content hash of their inputs matches.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from microslip.geometry.mesh import SurfaceContact
from microslip.geometry.pairing import paired_contact
from microslip.geometry.stored import written_whole

from . import cyclic, fem, linalg
from .fem import Damping, IntArray, Material, MeshLike

#: A reduced model's lowest frequency below this fraction of its highest is a rigid mode
RIGID = 1e-5

#: Bump when the stored layout or the algorithm changes (invalidates caches).
#: 2: reduced load vectors (``ReducedModel.loads``, the centrifugal load at ND 0).
FORMAT_VERSION = 2
#: Name of the centrifugal load (per unit Omega^2) in ``ReducedModel.loads``.
CENTRIFUGAL = "centrifugal"
#: Default fixed-interface mode selection: "auto" keeps every mode below CUTOFF x f_ref, with
#: f_ref the INTEREST-th fixed-interface frequency (or a given f_max). An integer keeps that many.
DEFAULT_MODES = "auto"
#: Cut-off multiplier, chosen from measurement (``microslip bench reduction --cb``): the
#: CB error of the first ten frequencies behaves like (f_10 / f_cut)^2. Max error over the first
#: ten per ND, cut-off at c x the 10th fixed-interface frequency:
#:   c      annular sector (test model, ND 0-3)    blisk sector (default, ND 0/1/12/24)
#:   3.0    1.4e-3 (45-51 modes)                   2.6e-3 (27-32 modes)
#:   3.5    7.1e-4 (55-67 modes)                   1.6e-3 (33-41 modes)
#:   4.0    4.1e-4 (69-85 modes)                   6.4e-4 (40-51 modes)
#:   5.0    1.6e-4 (97-119 modes)                  1.9e-4 (56-79 modes)
#: so 4.0 meets the 0.1 % goal on both with a margin of 1.5-2.5. The 10th fixed-interface
#: frequency is above the 10th free-interface one (a constraint raises every eigenvalue), so the
#: cut-off is at least 4 x the highest frequency of interest.
CUTOFF = 4.0
#: Number of frequencies of interest per ND when no f_max is given.
INTEREST = 10
#: Convergence tolerance of the fixed-interface modes (shift-invert residual, ARPACK's measure).
#: CB is a Galerkin projection whatever the vectors (the master/mode coupling of k vanishes for
#: any Phi, and Phi^H K Phi is made diagonal by a final Rayleigh-Ritz), so the modes only need to
#: span the low subspace well: at 1e-6 the Ritz frequencies differ from those at 1e-10 by
#: 1e-10 relative (150k-DOF blisk, 30 modes) and the solver needs 15 block solves instead of 20.
EIGEN_TOL = 1e-6
#: Master columns solved per block (bounds the dense right-hand-side memory).
_BLOCK = 512


@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Reduced model of one body at one nodal diameter.

    stiffness, mass: (r, r) dense, float64 or complex128 Hermitian [N/m], [kg]
        (modal block in mass-normalised units).
    damping_spec: linear damping applied to the reduced model (``damping`` gives the matrix).
    master_nodes: (n_m,) global mesh point indices (nodes, or points averaging nodes: a
        contact grid apart from the mesh, ``AveragedMasters``); master_coordinates (n_m, 3)
        [m].
    n_modes: fixed-interface (CB) or normal (modal) modes kept; r = 3 n_m + n_modes.
    mode_frequencies: (n_modes,) [Hz] of those modes.
    patches: contact-patch name -> (k,) global node indices of that patch in this body
        (a subset of master_nodes).
    recovery_nodes: (p,) global node indices; recovery: (p, 3, r), u(node) = recovery @ q.
    nodal_diameter, sectors: None for a body without cyclic symmetry.
    loads: load name -> (r,) reduced load vector, dtype of the model (complex at 0 < h < Ns/2),
        the generalized force on q of an FE load on the body DOFs (q^H loads[name] is its
        virtual work). "centrifugal" (``CENTRIFUGAL``): per unit Omega^2, N/(rad/s)^2 on the
        master DOFs (the modal entries in the units of the mass-normalised modes), present at
        ND 0 of a cyclic body and for a body without cyclic symmetry.
    key: content hash of everything that produced the reduction (the damping spec is a
        separate field, applied without re-reducing). A mass study scales the mass by a
        multiplier in the harmonic balance (``LinearDynamics.mass``): exact, since re-reducing
        with density s rho spans the same subspace.
    """

    body: str
    method: str
    stiffness: NDArray
    mass: NDArray
    master_nodes: IntArray
    master_coordinates: NDArray[np.float64]
    n_modes: int
    mode_frequencies: NDArray[np.float64]
    recovery_nodes: IntArray
    recovery: NDArray
    nodal_diameter: int | None = None
    sectors: int | None = None
    patches: Mapping[str, IntArray] = field(default_factory=dict)
    damping_spec: Damping | None = None
    key: str = ""
    loads: Mapping[str, NDArray] = field(default_factory=dict)

    # --- sizes and maps the harmonic balance needs ---------------------------------------

    @property
    def n_masters(self) -> int:
        """Number of master DOFs (3 per master node)."""
        return 3 * len(self.master_nodes)

    @property
    def size(self) -> int:
        return int(self.stiffness.shape[0])

    @property
    def master_dof_nodes(self) -> IntArray:
        """(n_masters,) global node index of each master coordinate."""
        return np.repeat(self.master_nodes, 3)

    @property
    def master_dof_directions(self) -> IntArray:
        """(n_masters,) Cartesian direction 0/1/2 (x/y/z) of each master coordinate."""
        return np.tile(np.arange(3, dtype=np.int64), len(self.master_nodes))

    def dof_index(self, nodes: Sequence[int] | IntArray) -> IntArray:
        """(k, 3) reduced-coordinate indices of the x, y, z DOFs of master ``nodes``."""
        nodes = np.asarray(nodes, dtype=np.int64).ravel()
        order = np.argsort(self.master_nodes)
        pos = np.searchsorted(self.master_nodes, nodes, sorter=order)
        pos = order[np.minimum(pos, len(order) - 1)] if len(order) else pos
        if len(order) == 0 or np.any(self.master_nodes[pos] != nodes):
            missing = nodes if len(order) == 0 else nodes[self.master_nodes[pos] != nodes]
            raise ValueError(
                f"nodes {missing[:8].tolist()} are not masters of the reduced model of "
                f"{self.body!r}"
            )
        return 3 * pos[:, None] + np.arange(3)

    def patch_dofs(self, name: str) -> IntArray:
        """(k, 3) reduced-coordinate indices of a contact patch's nodes in this body."""
        if name not in self.patches:
            raise ValueError(f"patch {name!r} is not in this model; has {sorted(self.patches)}")
        return self.dof_index(self.patches[name])

    def recover(self, q: NDArray, nodes: Sequence[int] | IntArray | None = None) -> NDArray:
        """Displacements (p, 3) (or (p, 3, k) for q (r, k)) of recovery nodes from q."""
        R = self.recovery
        if nodes is not None:
            nodes = np.asarray(nodes, dtype=np.int64).ravel()
            pos = np.searchsorted(self.recovery_nodes, nodes)
            pos = np.minimum(pos, max(len(self.recovery_nodes) - 1, 0))
            if len(self.recovery_nodes) == 0 or np.any(self.recovery_nodes[pos] != nodes):
                raise ValueError(f"nodes={nodes[:8].tolist()}: not all are recovery nodes")
            R = R[pos]
        return R @ q

    @property
    def damping(self) -> NDArray | None:
        """(r, r) damping matrix [N s/m] from ``damping_spec``, or None."""
        return fem.damping_matrix(self.stiffness, self.mass, self.damping_spec)

    def matrices(self, conjugate: bool = False) -> tuple[NDArray, NDArray, NDArray]:
        """(K, M, C) dense; C zero if undamped; complex conjugates for a backward wave."""
        C = self.damping
        C = np.zeros_like(self.stiffness) if C is None else C
        if conjugate:
            return self.stiffness.conj(), self.mass.conj(), C.conj()
        return self.stiffness, self.mass, C

    # --- derived models ------------------------------------------------------------------

    def with_damping(self, damping: Damping | None) -> ReducedModel:
        """Same reduction with another linear damping spec (no re-reduction)."""
        return replace(self, damping_spec=damping)

    def frequencies(self, k: int | None = None) -> NDArray[np.float64]:
        """Lowest natural frequencies [Hz] of the reduced model (free masters)."""
        f = self._frequencies
        return f if k is None else f[:k]

    @cached_property
    def _frequencies(self) -> NDArray[np.float64]:
        lam = np.linalg.eigvalsh(_generalized(self.stiffness, self.mass))
        return np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    @property
    def has_rigid_mode(self) -> bool:
        """Whether the model (masters free) moves as a rigid body, its own stiffness not
        holding it (a damper, a blade held in its slot by its contacts): its lowest
        frequency below RIGID of its highest (round-off puts a rigid mode's near 1e-8 of
        it; a body's first elastic mode lies far above 1e-5)."""
        f = self._frequencies
        return bool(f[0] < RIGID * f[-1])

    # --- HDF5 ----------------------------------------------------------------------------

    def save(self, path: str | Path, group: str = "/") -> Path:
        """Write to an HDF5 file (group ``group``), replacing what is there."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        with h5py.File(path, "a") as f:
            self.save_into(f, group)
        return path

    def save_into(self, f: h5py.File, group: str = "/") -> None:
        """Write into the open HDF5 file ``f`` (group ``group``), replacing what is
        there."""
        if group != "/" and group in f:
            del f[group]
        g = f.require_group(group)
        for name in list(g):
            del g[name]
        for name in ("stiffness", "mass", "master_nodes", "master_coordinates",
                     "mode_frequencies", "recovery_nodes", "recovery"):
            g.create_dataset(name, data=np.asarray(getattr(self, name)))
        pg = g.create_group("patches")
        for name, nodes in self.patches.items():
            pg.create_dataset(name, data=np.asarray(nodes, dtype=np.int64))
        lg = g.create_group("loads")
        for name, vector in self.loads.items():
            lg.create_dataset(name, data=np.asarray(vector))
        g.attrs["format_version"] = FORMAT_VERSION
        g.attrs["body"] = self.body
        g.attrs["method"] = self.method
        g.attrs["n_modes"] = self.n_modes
        g.attrs["nodal_diameter"] = -1 if self.nodal_diameter is None else self.nodal_diameter
        g.attrs["sectors"] = -1 if self.sectors is None else self.sectors
        g.attrs["key"] = self.key
        spec = self.damping_spec
        g.attrs["damping"] = json.dumps(
            None if spec is None else [spec.rayleigh_alpha, spec.rayleigh_beta,
                                       list(spec.modal_ratios)]
        )

    @classmethod
    def load(cls, path: str | Path, group: str = "/") -> ReducedModel:
        """Read a model written by ``save``."""
        with h5py.File(path, "r") as f:
            g = f[group]
            if int(g.attrs["format_version"]) != FORMAT_VERSION:
                raise ValueError(f"{path}: format_version {g.attrs['format_version']} != "
                                 f"{FORMAT_VERSION}")
            arrays = {name: g[name][()] for name in (
                "stiffness", "mass", "master_nodes", "master_coordinates",
                "mode_frequencies", "recovery_nodes", "recovery")}
            patches = {name: g["patches"][name][()] for name in g["patches"]}
            loads = {name: g["loads"][name][()] for name in g["loads"]}
            spec = json.loads(g.attrs["damping"])
            nd, ns = int(g.attrs["nodal_diameter"]), int(g.attrs["sectors"])
            return cls(
                body=str(g.attrs["body"]),
                method=str(g.attrs["method"]),
                n_modes=int(g.attrs["n_modes"]),
                nodal_diameter=None if nd < 0 else nd,
                sectors=None if ns < 0 else ns,
                patches=patches,
                damping_spec=None if spec is None else Damping(spec[0], spec[1], tuple(spec[2])),
                key=str(g.attrs["key"]),
                loads=loads,
                **arrays,
            )


def _generalized(K: NDArray, M: NDArray) -> NDArray:
    """L^-1 K L^-H with M = L L^H: the standard Hermitian form of (K, M)."""
    L = np.linalg.cholesky(0.5 * (M + M.conj().T))
    X = np.linalg.solve(L, 0.5 * (K + K.conj().T))
    A = np.linalg.solve(L, X.conj().T)
    return 0.5 * (A + A.conj().T)


def _hash(obj: object) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def _nodes_digest(nodes: NDArray) -> str:
    a = np.ascontiguousarray(np.asarray(nodes, dtype=np.int64))
    return hashlib.sha256(a.tobytes()).hexdigest()


def reduction_key(
    model: cyclic.SectorModel,
    method: str,
    master_nodes: IntArray,
    n_modes: int | str,
    recovery_nodes: IntArray,
    patches: Mapping[str, IntArray] | None = None,
    cutoff: float = CUTOFF,
    f_max: float | None = None,
    loads: Iterable[str] = (),
    averaged: AveragedMasters | None = None,
) -> str:
    """Content hash of the inputs of a reduction (mesh, body, material, order, constraints,
    ND, masters, modes, recovery nodes, patches, names of the projected loads, format
    version). Load vectors enter by name only: those ``reduce_body`` projects are functions
    of mesh, body, material and order, already in the hash."""
    body = model.body
    key = _key(body.mesh_hash, body.body, body.order, body.material, model.clamped_nodes,
               model.nodal_diameter, method, master_nodes, n_modes, recovery_nodes, patches,
               cutoff, f_max, loads, model.supports)
    return key if averaged is None else _hash([key, averaged.digest])


def _key(mesh_hash: str, body: str, order: int, material: Material, clamped: IntArray,
         nodal_diameter: int | None, method: str, master_nodes: IntArray, n_modes: int | str,
         recovery_nodes: IntArray, patches: Mapping[str, IntArray] | None,
         cutoff: float = CUTOFF, f_max: float | None = None,
         loads: Iterable[str] = (), supports: Sequence[Any] = ()) -> str:
    # (supports enter only where there are some: the keys of models without stay as they were)
    held = {"supports": [s.digest for s in supports]} if supports else {}
    return _hash(held | {
        "format": FORMAT_VERSION,
        "mesh": mesh_hash,
        "body": body,
        "order": int(order),
        "material": material.as_tuple(),
        "clamped": _nodes_digest(np.unique(clamped)),
        "nd": nodal_diameter,
        "method": method,
        "masters": _nodes_digest(master_nodes),
        "modes": _mode_selection(n_modes, cutoff, f_max),
        "recovery": _nodes_digest(np.unique(recovery_nodes)),
        "patches": {k: _nodes_digest(v) for k, v in (patches or {}).items()},
        "loads": sorted(loads),
    })


# --- the reductions ---------------------------------------------------------------------


def _check_nodes(nodes: Sequence[int] | IntArray, what: str) -> IntArray:
    arr = np.asarray(nodes, dtype=np.int64).ravel()
    if len(np.unique(arr)) != len(arr):
        raise ValueError(f"{what}: node indices must be distinct")
    return arr


def _mode_selection(n_modes: int | str, cutoff: float, f_max: float | None) -> object:
    """What the mode selection is, for the content hash."""
    if isinstance(n_modes, str):
        return [n_modes, float(cutoff), None if f_max is None else float(f_max), INTEREST]
    return int(n_modes)


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
    _check_modes(n_modes, available, "slave")


def _check_modes(n_modes: int, available: int, what: str) -> None:
    if not (isinstance(n_modes, int | np.integer) and 0 <= n_modes <= available):
        raise ValueError(
            f"n_modes={n_modes!r}: must be an integer in 0..{available} "
            f"(the {what} space has {available} DOFs)"
        )


def _check_loads(model: cyclic.SectorModel, loads: Mapping[str, NDArray] | None
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


def _free_loads(model: cyclic.SectorModel, loads: Mapping[str, NDArray]) -> dict[str, NDArray]:
    """Loads on the free coordinates: P_h^H f (clamped DOFs drop out; a right-face entry goes to
    its left-face image, rotated back and phase-shifted as the DOFs are)."""
    PH = model.expansion.conj().T.tocsr()
    return {name: PH @ f for name, f in loads.items()}


def _recovery_rows(model: cyclic.SectorModel, nodes: IntArray) -> sp.csr_matrix:
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
        see ``linalg.lowest_modes``.
    loads: name -> (N,) FE load vector on the body DOFs (e.g. ``fem.centrifugal_load``),
        projected as T^H P_h^H f = [f_m + Psi^H f_s ; Phi_s^H f_s] into ``ReducedModel.loads``.
    averaged: the masters that are averages of body nodes (``averaged_masters``): their
        coordinates are W u, the static modes the least-energy fields with W u = e_j (and
        W u = 0 for the nodes' columns), the fixed-interface modes those with W u = 0
        (``linalg.ConstrainedFactor``); a force on them reaches the nodes as W^H f.
    All inputs are checked before any factorization.
    """
    selection = n_modes
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
    n_s = n_f - len(m_idx)
    n_s_free = n_s - 3 * int(is_averaged.sum())  # (the slave space less the averages held)
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
    loads = _check_loads(model, loads)

    is_master = np.zeros(n_f, dtype=bool)
    is_master[m_idx] = True
    s_idx = np.flatnonzero(~is_master)
    K, M = model.stiffness, model.mass
    K_s = K[s_idx]
    M_s = M[s_idx]
    K_ss, K_sm = K_s[:, s_idx].tocsr(), K_s[:, m_idx].tocsc()
    M_ss, M_sm = M_s[:, s_idx].tocsr(), M_s[:, m_idx].tocsc()
    K_mm = K[m_idx][:, m_idx].toarray()
    M_mm = M[m_idx][:, m_idx].toarray()
    dtype = np.result_type(K.dtype, M.dtype)

    t0 = time.perf_counter()
    n_m, n_c = len(m_idx), 3 * len(masters)
    if is_averaged.any():
        W = _averaging(model, averaged, masters[is_averaged])
        W_s, W_m = W[:, s_idx], W[:, m_idx].tocsc()
        factor = linalg.ConstrainedFactor(K_ss, W_s, backend)
    else:
        factor = linalg.factorize(K_ss, backend=backend, positive_definite=True)
    t1 = time.perf_counter()
    Psi = np.empty((n_s, n_c), dtype=dtype, order="F")
    for j in range(0, n_m, _BLOCK):
        block = slice(j, min(j + _BLOCK, n_m))
        if is_averaged.any():  # u_m = e_j, W u = 0
            Psi[:, cols[block]] = factor.solve((-K_sm[:, block]).toarray(),
                                               (-W_m[:, block]).toarray())
        else:
            Psi[:, cols[block]] = factor.solve((-K_sm[:, block]).toarray())  # negated sparse
    if is_averaged.any():  # u_m = 0, W u = e_j
        tied = (3 * np.flatnonzero(is_averaged)[:, None] + np.arange(3)).ravel()
        Psi[:, tied] = factor.solve(np.zeros((n_s, len(tied)), dtype),
                                    np.eye(len(tied), dtype=dtype))
    t2 = time.perf_counter()
    if n_modes == "auto" and n_s > 0:
        if f_max is None:
            k0 = min(INTEREST, n_s_free)
            upper = lambda lam: cutoff**2 * lam[-1]  # noqa: E731
        else:
            k0, upper = 1, (2.0 * np.pi * cutoff * f_max) ** 2
        lam, Phi = linalg.lowest_modes(K_ss, M_ss, k0, factor=factor, upper=upper,
                                       method=eigen_method, tol=EIGEN_TOL)
        n_modes = len(lam)
    elif n_modes != "auto" and n_modes > 0:
        lam, Phi = linalg.lowest_modes(K_ss, M_ss, int(n_modes), factor=factor,
                                       method=eigen_method, tol=EIGEN_TOL)
    else:
        lam, Phi = np.empty(0), np.empty((n_s, 0), dtype=dtype)
        n_modes = 0
    factor.free()
    t3 = time.perf_counter()

    # Reduced stiffness: the Schur complement (Hermitian part) where every master is a node
    # (K_ss Psi = -K_sm), the whole quadratic form where some are averages (there K_ss Psi
    # = -K_sm - W^H lam); the modal diagonal.
    if is_averaged.any():
        K_hat = _master_block(K_mm, K_sm, K_ss, Psi, cols)
    else:
        K_hat = K_mm + (K_sm.conj().T @ Psi)
        K_hat = 0.5 * (K_hat + K_hat.conj().T)
    M_hat = _master_block(M_mm, M_sm, M_ss, Psi, cols)
    M_SPhi = linalg.spmm(M_ss, Phi)
    M_meta = (M_SPhi.conj().T @ Psi).conj().T
    M_meta[cols] += M_sm.conj().T @ Phi
    M_eta = Phi.conj().T @ M_SPhi
    M_eta = 0.5 * (M_eta + M_eta.conj().T)

    r = n_c + n_modes
    k_red = np.zeros((r, r), dtype=dtype)
    m_red = np.zeros((r, r), dtype=dtype)
    k_red[:n_c, :n_c] = K_hat
    k_red[n_c:, n_c:] = np.diag(lam)
    m_red[:n_c, :n_c] = M_hat
    m_red[:n_c, n_c:] = M_meta
    m_red[n_c:, :n_c] = M_meta.conj().T
    m_red[n_c:, n_c:] = M_eta

    # Recovery rows: u_body = P (u_free), u_free[m] = q_m, u_free[s] = Psi q_m + Phi eta.
    if len(recovery):
        rows = _recovery_rows(model, recovery)
        R = np.zeros((rows.shape[0], r), dtype=np.result_type(dtype, rows.dtype))
        R[:, cols] = rows[:, m_idx].toarray()
        Rs = rows[:, s_idx]
        R[:, :n_c] += Rs @ Psi
        R[:, n_c:] = Rs @ Phi
        R = R.reshape(len(recovery), 3, r)
    else:
        R = np.zeros((0, 3, r), dtype=dtype)

    # Loads: T^H P^H f = [f_m + Psi^H f_s ; Phi^H f_s] (as (Psi^T conj(f_s))^*: no copy of
    # Psi^H).
    reduced_loads = {}
    for name, f in _free_loads(model, loads).items():
        f_s = f[s_idx].conj()
        red = np.empty(r, dtype=np.result_type(dtype, f.dtype))
        red[:n_c] = (Psi.T @ f_s).conj()
        red[cols] += f[m_idx]
        red[n_c:] = (Phi.T @ f_s).conj()
        reduced_loads[name] = red
    t4 = time.perf_counter()
    if timings is not None:
        timings.update(factorize=t1 - t0, static_modes=t2 - t1, eigen=t3 - t2,
                       projection=t4 - t3, backend=backend)

    return ReducedModel(
        body=model.body.body,
        method="craig-bampton",
        stiffness=k_red,
        mass=m_red,
        master_nodes=masters,
        master_coordinates=_master_xyz(model, masters, is_averaged, averaged),
        n_modes=int(n_modes),
        mode_frequencies=np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi),
        recovery_nodes=recovery,
        recovery=R,
        nodal_diameter=model.nodal_diameter,
        sectors=model.sectors,
        patches=patches,
        damping_spec=damping,
        key=reduction_key(model, "craig-bampton", masters, selection, recovery, patches,
                          cutoff, f_max, loads, averaged),
        loads=reduced_loads,
    )


def _master_xyz(model: cyclic.SectorModel, masters: IntArray, is_averaged: NDArray,
                averaged: AveragedMasters | None) -> NDArray[np.float64]:
    """(n_m, 3) [m] the masters' positions (nodes' and averaged points')."""
    xyz = np.empty((len(masters), 3))
    xyz[~is_averaged] = model.body.points[model.body.local_nodes(masters[~is_averaged])]
    if is_averaged.any():
        xyz[is_averaged] = averaged.xyz[np.searchsorted(averaged.points,
                                                        masters[is_averaged])]
    return xyz


def modal_reduction(
    model: cyclic.SectorModel,
    n_modes: int,
    recovery_nodes: Sequence[int] | IntArray = (),
    damping: Damping | None = None,
    sigma: float = 0.0,
    backend: str | None = None,
    loads: Mapping[str, NDArray] | None = None,
) -> ReducedModel:
    """Modal superposition (eqs. 33-36): q = eta, the amplitudes of the lowest n_modes modes.

    k = diag(omega^2), m = I; no master coordinates: contact displacements come from the
    recovery matrix (u = Psi eta on ``recovery_nodes``, which must include the contact nodes),
    contact forces go back as Psi^H f (eq. 36). ``sigma`` [rad^2/s^2] is the shift; use a
    negative one for a body with rigid-body modes. ``loads``: name -> (N,) FE load vector on
    the body DOFs, projected as Phi^H P_h^H f (modal forces) into ``ReducedModel.loads``.
    """
    recovery = np.unique(np.asarray(recovery_nodes, dtype=np.int64))
    _check_modes(n_modes, model.n_free, "free")
    if n_modes == 0:
        raise ValueError("n_modes=0: modal superposition needs at least one mode")
    if len(recovery):
        model.body.local_nodes(recovery, "recovery_nodes")
    loads = _check_loads(model, loads)
    lam, Phi = linalg.lowest_modes(model.stiffness, model.mass, int(n_modes), sigma=sigma,
                                   backend=backend)
    if len(recovery):
        R = (_recovery_rows(model, recovery) @ Phi).reshape(len(recovery), 3, n_modes)
    else:
        R = np.zeros((0, 3, n_modes), dtype=Phi.dtype)
    reduced_loads = {name: Phi.conj().T @ f for name, f in _free_loads(model, loads).items()}
    return ReducedModel(
        body=model.body.body,
        method="modal",
        stiffness=np.diag(lam).astype(Phi.dtype),
        mass=np.eye(n_modes, dtype=Phi.dtype),
        master_nodes=np.empty(0, dtype=np.int64),
        master_coordinates=np.empty((0, 3)),
        n_modes=int(n_modes),
        mode_frequencies=np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi),
        recovery_nodes=recovery,
        recovery=R,
        nodal_diameter=model.nodal_diameter,
        sectors=model.sectors,
        damping_spec=damping,
        key=reduction_key(model, "modal", np.empty(0, np.int64), n_modes, recovery,
                          loads=loads),
        loads=reduced_loads,
    )


# --- stage function with the HDF5 cache --------------------------------------------------


class ReductionError(RuntimeError):
    """A body's reduction failed for a numerical reason (the message names the body, the
    ND, what was tried and what to change)."""


@dataclass(frozen=True)
class BodySpec:
    """What to reduce for one body of a mesh.

    master_sets / recovery_sets / clamped_sets: node-set names (see the geometry models).
    supports: nodes held in some directions (``geometry.mesh.Support``: a deck's, a case's).
    recovery_surface: also recover the vertices of the body's outer surface (what a
    picture of the deformed body draws).
    patches: contact-patch names whose nodes in this body are masters.
    n_modes, cutoff, f_max: fixed-interface mode selection (see ``craig_bampton``).
    order: element order.
    """

    body: str
    material: Material
    master_sets: tuple[str, ...] = ()
    patches: tuple[str, ...] = ()
    recovery_sets: tuple[str, ...] = ()
    recovery_surface: bool = False
    clamped_sets: tuple[str, ...] = ()
    supports: tuple[Any, ...] = ()
    n_modes: int | str = DEFAULT_MODES
    cutoff: float = CUTOFF
    f_max: float | None = None
    order: int = 2
    damping: Damping | None = None


def patch_nodes(mesh: MeshLike, name: str, body: str) -> IntArray:
    """Nodes of contact patch ``name`` that belong to ``body`` (either side, grid order;
    both sides, a's then b's, when the body touches its neighbouring sector; sorted, for
    named surfaces)."""
    if name not in mesh.contacts:
        raise ValueError(f"contact patch {name!r} does not exist; available: "
                         f"{sorted(mesh.contacts)}")
    patch = mesh.contacts[name]
    if isinstance(patch, SurfaceContact):  # named surfaces: the nodes their pairs use
        if body not in (patch.body_a, patch.body_b):
            raise ValueError(f"contact {name!r} joins {patch.body_a!r} and "
                             f"{patch.body_b!r}, not body {body!r}")
        return paired_contact(mesh, name).nodes_of(body)
    if patch.body_a == body == patch.body_b:
        return np.concatenate([np.asarray(patch.nodes_a, dtype=np.int64).ravel(),
                               np.asarray(patch.nodes_b, dtype=np.int64).ravel()])
    if patch.body_a == body:
        return np.asarray(patch.nodes_a, dtype=np.int64).ravel()
    if patch.body_b == body:
        return np.asarray(patch.nodes_b, dtype=np.int64).ravel()
    raise ValueError(f"contact patch {name!r} joins {patch.body_a!r} and {patch.body_b!r}, "
                     f"not body {body!r}")


def spec_nodes(mesh: MeshLike, spec: BodySpec) -> tuple[IntArray, dict, IntArray, IntArray]:
    """(masters, patch name -> nodes, recovery nodes, clamped nodes) of a BodySpec; ValueError
    naming any node set or patch the mesh does not have, a body without masters, or masters
    without DOFs of their own (clamped, or on the cyclic face that follows the other)."""
    patches = {name: patch_nodes(mesh, name, spec.body) for name in spec.patches}
    masters = [*patches.values(), fem.node_sets_union(mesh, list(spec.master_sets))]
    master_nodes = np.unique(np.concatenate(masters)).astype(np.int64)
    recovery = fem.node_sets_union(mesh, list(spec.recovery_sets))
    if spec.recovery_surface:
        recovery = np.union1d(recovery, mesh.surface(spec.body))
    clamped = fem.node_sets_union(mesh, list(spec.clamped_sets))
    where = f"[reduction.bodies.{spec.body}] masters"
    if not len(master_nodes):
        raise ValueError(f"{where}: body {spec.body!r} has no master nodes (no contact of "
                         "its own, no node set named): name its interface nodes")
    cyc = mesh.cyclic.get(spec.body)
    follow = () if cyc is None else (cyc.right if cyc.slave_is_right else cyc.left)
    supported = (np.unique(np.concatenate([s.nodes for s in spec.supports]))
                 if spec.supports else np.empty(0, np.int64))
    for what, nodes in (("clamped", clamped), ("on the cyclic face that follows the other",
                                               follow), ("held by a support", supported)):
        bad = np.intersect1d(master_nodes, nodes)
        if len(bad):
            raise ValueError(f"{where}: {len(bad)} node(s) of body {spec.body!r} are {what} "
                             f"(first {bad[:5].tolist()}): masters need DOFs of their own")
    return master_nodes, patches, recovery, clamped


def model_path(mesh: MeshLike, spec: BodySpec, nodal_diameter: int | None,
               cache_dir: str | Path) -> Path:
    """Where ``reduce_body`` stores (and looks for) the model of ``spec`` at an ND (None for a
    body without cyclic symmetry): ``cache_dir/cb-<content hash>.h5``."""
    return _path(cache_dir, mesh, spec, *spec_nodes(mesh, spec), nodal_diameter)


def _path(cache_dir: str | Path, mesh: MeshLike, spec: BodySpec, master_nodes: IntArray,
          patches: dict, recovery: IntArray, clamped: IntArray,
          nodal_diameter: int | None) -> Path:
    key = _key(mesh.content_hash, spec.body, spec.order, spec.material, clamped,
               nodal_diameter, "craig-bampton", master_nodes, spec.n_modes, recovery, patches,
               spec.cutoff, spec.f_max, _body_load_names(nodal_diameter), spec.supports)
    return Path(cache_dir) / f"cb-{key[:32]}.h5"


def _body_load_names(nodal_diameter: int | None) -> tuple[str, ...]:
    """Names of the loads ``reduce_body`` projects at an ND (None: no cyclic symmetry): the
    centrifugal load is axisymmetric, so only ND 0 (or a non-cyclic body) carries it."""
    return (CENTRIFUGAL,) if nodal_diameter in (None, 0) else ()


def reference_frequency(models: Iterable[ReducedModel]) -> float | None:
    """The highest INTEREST-th (10th) fixed-interface frequency [Hz] among ``models`` (None if
    none has that many modes): the top of the range they resolve, the f_max to give a body whose
    own modes lie far above it (the free damper beside the disk)."""
    f = [m.mode_frequencies[INTEREST - 1] for m in models if m.n_modes >= INTEREST]
    return float(max(f)) if f else None


def _eigen_failure(spec: BodySpec, h: int, n_free: int, backend: str | None, is_cyclic: bool,
                   err: Exception) -> str:
    """What a failed fixed-interface eigen-solve says: where, what was tried, what to change."""
    where = f"body {spec.body!r}" + (f" at ND {h}" if is_cyclic else "")
    solver = linalg.check_backend(backend, n_free)
    wanted = (f"every mode below {spec.cutoff:g} x the reference frequency" if spec.n_modes
              == "auto" else f"{spec.n_modes} modes")
    other = [b for b in linalg.available_backends() if b != solver]
    fewer = ("lower [reduction] cutoff or set " if spec.n_modes == "auto" else "set ")
    return (f"reduction of {where} ({n_free} free DOFs): the fixed-interface eigen-solve "
            f"(block shift-invert Lanczos, {wanted}, {solver} factorization) failed: {err}; "
            f"to change: {fewer}[reduction.bodies.{spec.body}] modes to fewer modes"
            + (f", or set [reduction] backend = \"{other[0]}\"" if other else ""))


def reduce_body(
    mesh: MeshLike,
    spec: BodySpec,
    nodal_diameters: Sequence[int] = (0,),
    cache_dir: str | Path | None = None,
    backend: str | None = None,
    report: Callable[[int, ReducedModel, Path | None, bool, float], None] | None = None,
) -> dict[int, ReducedModel]:
    """Craig-Bampton models of one body for each ND (a non-cyclic body: ND ignored, one model
    reused for all). Cached in ``cache_dir/<key>.h5``; the body is assembled once, and only on
    a cache miss. The model of ND 0 (and that of a non-cyclic body) carries the centrifugal
    load per unit Omega^2 in ``loads["centrifugal"]`` (see ``fem.centrifugal_load``); the
    other NDs have no load.

    report: called after each model as report(ND, model, file or None, from cache, seconds);
        a non-cyclic body reports once, as ND 0.
    """
    master_nodes, patches, recovery, clamped = spec_nodes(mesh, spec)
    boundary = mesh.cyclic.get(spec.body)
    if boundary is not None:
        for h in nodal_diameters:
            cyclic.check_nodal_diameter(h, boundary.sectors)
    nds = sorted(set(int(h) for h in nodal_diameters)) if boundary is not None else [0]
    out: dict[int, ReducedModel] = {}
    body_model = None
    for h in nds:
        t = time.perf_counter()
        path = None if cache_dir is None else _path(cache_dir, mesh, spec, master_nodes, patches,
                                                   recovery, clamped,
                                                   h if boundary is not None else None)
        model = _load(path, spec.damping)
        cached = model is not None
        if not cached:
            if body_model is None:
                body_model = fem.assemble(mesh, spec.body, spec.material, spec.order)
            sector = cyclic.sector_model(body_model, clamped, boundary, h, spec.supports)
            names = _body_load_names(h if boundary is not None else None)
            loads = {CENTRIFUGAL: fem.centrifugal_load(body_model)} if names else None
            try:
                model = craig_bampton(sector, master_nodes, spec.n_modes, recovery, patches,
                                      spec.damping, backend, cutoff=spec.cutoff,
                                      f_max=spec.f_max, loads=loads,
                                      averaged=averaged_masters(mesh, master_nodes))
            except linalg.EigenSolverError as err:
                raise ReductionError(_eigen_failure(spec, h, sector.n_free, backend,
                                                    boundary is not None, err)) from err
            if path is not None and not _kept(model, path):
                path = None  # (the cache could not be written: the run goes on)
        out[h] = model
        if report is not None:
            report(h, model, path, cached, time.perf_counter() - t)
    if boundary is None:
        return {int(h): out[0] for h in nodal_diameters}
    return out


def _load(path: Path | None, damping: Damping | None) -> ReducedModel | None:
    """The cached model at ``path`` with ``damping``, or None (absent, or unreadable: an older
    format or a damaged file, reduced again and replaced)."""
    if path is None or not path.exists():
        return None
    try:
        return ReducedModel.load(path).with_damping(damping)
    except (OSError, KeyError, ValueError):
        return None


def _kept(model: ReducedModel, path: Path) -> bool:
    """Whether ``model`` was kept at ``path`` (a cache that cannot take it, full or
    emptied meanwhile, only costs the next run the reduction)."""
    try:  # whole or not at all: a later run never takes a half-written model for a hit
        written_whole(path, model.save_into)
    except OSError:
        return False
    return True

