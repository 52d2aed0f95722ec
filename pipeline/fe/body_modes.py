"""Natural frequencies and mode shapes of a body as its deck has it, unreduced, against its
reduced model's: what a user compares with their FE tool first.

The body is held as its reduction holds it (``BodySpec``: clamped sets, supports; the cyclic
condition of a nodal diameter), its masters free; the reduced model (Craig-Bampton) with its
master DOFs free has the same constraints, so its lowest eigenvalues are Rayleigh-Ritz upper
bounds of these, and their difference is the reduction's error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import cyclic, eigen, fem
from .bodies import BodySpec, spec_nodes
from .fem import MeshLike
from .reduced_model import ReducedModel

#: A body neither clamped nor supported is free: its rigid modes sit at 0, so the
#: shift-invert solve shifts below them by this fraction of its reduced model's first
#: elastic eigenvalue (a shift of zero would factor a singular matrix). Also the sharpest
#: of the rigid modes' eigenvalues: ~ this x the first elastic one x 1e-12 (the solver's
#: residual), far below any elastic mode.
FREE_SHIFT = 1e-2


@dataclass(frozen=True)
class BodyModes:
    """The lowest modes of one body at one nodal diameter (None: not cyclic).

    frequencies_hz: (k,) of the unreduced body; reduced_hz: (k,) of its reduced model (with
    free masters); nodes: (n_v,) the body's vertices; shapes: (k, n_v, 3) their
    displacements in each mode (mass-normalised over the sector; complex at 0 < h < Ns/2),
    or None; n_free: the unreduced body's free DOFs.
    """

    body: str
    nodal_diameter: int | None
    frequencies_hz: NDArray[np.float64]
    reduced_hz: NDArray[np.float64]
    nodes: NDArray[np.int64]
    shapes: NDArray | None
    n_free: int

    @property
    def relative_error(self) -> NDArray[np.float64]:
        """(k,) reduced / unreduced frequency - 1 (0 where both are rigid modes)."""
        f, r = self.frequencies_hz, self.reduced_hz
        scale = np.maximum(np.abs(f), 1e-9 * max(float(np.abs(f).max(initial=0.0)), 1e-300))
        return (r - f) / scale


def frequencies_hz(lam: NDArray) -> NDArray[np.float64]:
    """Natural frequencies [Hz] of eigenvalues lambda = omega^2 [rad^2/s^2] (a rigid mode's
    round-off below zero gives 0)."""
    return np.sqrt(np.clip(np.real(lam), 0.0, None)) / (2 * np.pi)


def body_modes(mesh: MeshLike, spec: BodySpec, model: ReducedModel, count: int,
               nodal_diameter: int | None = None, shapes: bool = True,
               backend: str | None = None, body: fem.BodyModel | None = None) -> BodyModes:
    """The lowest ``count`` modes of ``spec``'s body, unreduced (held as its reduction holds
    it, at ``nodal_diameter``), beside those of its reduced ``model``. ``body``: the body's
    assembled model to reuse (one per body for every ND)."""
    body = body or fem.assemble(mesh, spec.body, spec.material, spec.order)
    clamped = spec_nodes(mesh, spec)[3]
    boundary = mesh.cyclic.get(spec.body)
    h = nodal_diameter if boundary is not None else 0
    sector = cyclic.sector_model(body, clamped, boundary, h or 0, spec.supports)
    count = min(count, sector.n_free)
    reduced = model.frequencies(count)
    held = clamped.size or spec.supports
    elastic = reduced[reduced > 1e-3 * reduced.max(initial=0.0)]
    first = float(2 * np.pi * elastic.min()) ** 2 if elastic.size else 1.0
    sigma = 0.0 if held else -FREE_SHIFT * first
    # solved shifted, (K - sigma M) phi = (lambda - sigma) M phi: a rigid mode has K phi = 0,
    # on which the solver's residual (relative to K phi) could not converge
    shifted = sector.stiffness - sigma * sector.mass if sigma else sector.stiffness
    lam, phi = eigen.lowest_modes(shifted, sector.mass, count, backend=backend)
    lam = lam + sigma
    vertex = None
    if shapes:
        u = sector.expansion @ phi[:, :count]  # (N, k) body DOFs
        vertex = np.moveaxis(u[body.node_dofs], 2, 0)  # (k, n_v, 3)
    return BodyModes(spec.body, nodal_diameter if boundary is not None else None,
                     frequencies_hz(lam[:count]), reduced, body.nodes, vertex, sector.n_free)
