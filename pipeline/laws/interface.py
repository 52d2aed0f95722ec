"""The contact-law interface: what the harmonic balance evaluates and the case reader builds.

A contact law (:class:`ContactLaw`) names the relative motions it acts on (the case keys
``u``, ``u1``, ``u2``, ``v``, ... that give them as combinations of DOFs) and builds, from a
case's ``[[contacts]]`` table, a set of contact points (:class:`ContactSet`). A contact set
gives the harmonic balance everything it needs of a nonlinearity: the force coefficients
of given relative-motion coefficients and their exact Jacobian (:meth:`ContactSet.evaluate`),
the stiffness of the stuck contact (the linear guess and the linear limits), the response
to the ``preload`` parameter, and a force scale.

Every law is in one registry, ``registry.LAWS`` (name -> law): the case reader validates
and builds through it, so a new law is a new entry there; laws A-D are one entry each,
sharing the fused compiled kernel of :mod:`.returnmap`; the springs of :mod:`.springs`
(polynomial, unilateral) evaluate by AFT.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from microslip.fourier import Harmonics

    from .coulomb import ContactResponse


class ContactSet(Protocol):
    """P contact points of one law: what the harmonic balance evaluates.

    The relative motion of each point has ``n_components`` components (in the order of the
    law's ``motions``); its coefficients g (P, n_components, nc) are in the layout of the
    harmonics."""

    @property
    def size(self) -> int:
        """P, the points."""

    @property
    def n_components(self) -> int:
        """Components of each point's relative motion."""

    def evaluate(self, g: np.ndarray, harmonics: Harmonics, *, jacobian: bool = True,
                 histories: bool = False, corrections: bool = True) -> ContactResponse:
        """Force coefficients (P, n_components, nc) [N] resisting the relative motion
        (on the DOFs: -B^T f) and, with ``jacobian``, their exact derivatives
        (P, n_components, nc, n_components, nc) [N/m]; states and energies per point;
        ``corrections``: the law's sub-sample corrections, where it has any."""

    def stuck_stiffness(self) -> np.ndarray:
        """(P, n_components) N/m: the stiffness of each component with the contact stuck
        (the tangent at rest), for the linear guess and the fully stuck linear limit."""

    def with_preload(self, multiplier: float) -> ContactSet:
        """The same points with the ``preload`` parameter at ``multiplier`` (1: as built);
        a law with no preload returns itself."""

    def preload_derivative(self, response: ContactResponse) -> np.ndarray:
        """(P, n_components, nc) d forces / d preload multiplier, from a response evaluated
        with the Jacobian (zeros for a law with no preload)."""

    def force_scale(self) -> float:
        """A force [N] typical of these points (the residual's scale when no load is
        given)."""


class ContactLaw(Protocol):
    """A contact law in the registry: its name, the relative motions it takes (case keys,
    in the order of a contact set's components) and how a case's table becomes points.
    A law with keys that are not numbers also has ``keys`` (their names) and ``check(pre,
    table, out)``, which appends a line per fault of them (the case reader calls it)."""

    @property
    def name(self) -> str: ...

    @property
    def motions(self) -> tuple[str, ...]: ...

    @property
    def parameters(self) -> tuple[str, ...]:
        """The numeric keys its case table gives, each required (the friction laws A-D
        have their own rules in the case reader)."""

    def elements(self, table: Mapping[str, Any], n_points: int = 1) -> ContactSet:
        """The contact set of a validated ``[[contacts]]`` table, its parameters the same
        at each of ``n_points`` points."""
