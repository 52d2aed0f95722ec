"""Every contact law by the name a case gives (``law = "A"``, ``"polynomial"``): the one
registry the case reader and the harmonic balance find laws in (:mod:`.interface`); a new law
is a new entry here."""

from __future__ import annotations

from .coulomb import FRICTION_LAWS
from .interface import ContactLaw
from .springs import PolynomialLaw, UnilateralLaw

LAWS: dict[str, ContactLaw] = {**FRICTION_LAWS, **{law.name: law for law in (
    PolynomialLaw(), UnilateralLaw())}}
