"""Modal superposition (Firrone & Zucca eqs. 33-36): the alternative to Craig-Bampton, q =
the amplitudes of a body's lowest normal modes, no master coordinates."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from . import cyclic, eigen
from .craig_bampton import check_loads, check_modes, free_loads, recovery_rows
from .fem import Damping, IntArray
from .reduced_model import ReducedModel, reduction_key


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
    check_modes(n_modes, model.n_free, "free")
    if n_modes == 0:
        raise ValueError("n_modes=0: modal superposition needs at least one mode")
    if len(recovery):
        model.body.local_nodes(recovery, "recovery_nodes")
    loads = check_loads(model, loads)
    lam, Phi = eigen.lowest_modes(model.stiffness, model.mass, int(n_modes), sigma=sigma,
                                   backend=backend)
    if len(recovery):
        R = (recovery_rows(model, recovery) @ Phi).reshape(len(recovery), 3, n_modes)
    else:
        R = np.zeros((0, 3, n_modes), dtype=Phi.dtype)
    reduced_loads = {name: Phi.conj().T @ f for name, f in free_loads(model, loads).items()}
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
