"""What couples the reduced bodies: contacts per patch, loads, rotation speed, outputs.

Plain frozen dataclasses, validated on creation (a bad value raises ValueError naming the
field, the value and what is allowed). The case file's [assembly] table maps onto them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Contact elements per node pair: "2D" one law-D element (2D tangential, variable normal
#: load, Firrone & Zucca section 3); "1D+1D" two orthogonal law-B elements (1D tangential
#: along t1 and t2, each with half the normal stiffness: Firrone & Zucca's choice for the
#: blade root, section 5.3.1).
ELEMENTS = ("2D", "1D+1D")
#: Named directions of loads and outputs at a node of the fundamental sector (x, y, z global;
#: radial, tangential, axial in the cylindrical frame of the node about the disk axis +z).
DIRECTIONS = ("x", "y", "z", "radial", "tangential", "axial")
#: How a load's total force is shared among its node set's nodes (NodalLoad.spread).
SPREADS = ("nodes", "area")
#: What the static anchor may be: a ratio of each pair's tangential stiffness (0: none).
STATIC_ANCHOR_RULE = "a ratio 0 <= r < 1 of the tangential contact stiffness (0: no anchor)"


def static_anchor_allowed(ratio: object) -> bool:
    """Whether ``ratio`` may anchor the pairs' mean tangential slip (STATIC_ANCHOR_RULE)."""
    return isinstance(ratio, (int, float)) and not isinstance(ratio, bool) \
        and math.isfinite(ratio) and 0 <= ratio < 1


def _finite(name: str, value: float, *, positive: bool = False, nonneg: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or (positive and v <= 0) or (nonneg and v < 0):
        bound = " > 0" if positive else (" >= 0" if nonneg else "")
        raise ValueError(f"{name} = {value!r}: expected a finite number{bound}")
    return v


def _direction(name: str, value: str | tuple[float, float, float]):
    if isinstance(value, str):
        if value not in DIRECTIONS:
            raise ValueError(f"{name} = {value!r}: expected one of {list(DIRECTIONS)} or "
                             "[dx, dy, dz]")
        return value
    vec = np.asarray(value, dtype=float)
    if vec.shape != (3,) or not np.all(np.isfinite(vec)) or np.linalg.norm(vec) == 0:
        raise ValueError(f"{name} = {value!r}: expected one of {list(DIRECTIONS)} or a "
                         "non-zero vector [dx, dy, dz]")
    return tuple(float(x) for x in vec / np.linalg.norm(vec))


@dataclass(frozen=True)
class PatchFriction:
    """Friction contact on every node pair of one meshed patch.

    mu: friction coefficient [-]; interference: design interference [m] (negative: a gap),
    the geometric gap of each pair subtracted (Firrone & Zucca eq. 24:
    ``N = max(kn (Delta + v), 0)``);
    elements: see ELEMENTS; stiffness_scale: multiplier of the patch's contact stiffness
    (the flat-punch kn and kt of every pair; its uncertainty, e.g. from roughness);
    start_phase: where in the period [rad of the fundamental] the friction law's march
    starts (ContactElements.start_phase; the whole disk sets each sector's).
    """

    patch: str
    mu: float
    interference: float = 0.0
    elements: str = "2D"
    stiffness_scale: float = 1.0
    start_phase: float = 0.0

    def __post_init__(self):
        _finite(f"contacts.{self.patch}.mu", self.mu, nonneg=True)
        _finite(f"contacts.{self.patch}.interference", self.interference)
        _finite(f"contacts.{self.patch}.stiffness_scale", self.stiffness_scale, positive=True)
        _finite(f"contacts.{self.patch}.start_phase", self.start_phase)
        if self.elements not in ELEMENTS:
            raise ValueError(f"contacts.{self.patch}.elements = {self.elements!r}: expected one "
                             f"of {list(ELEMENTS)}")


@dataclass(frozen=True)
class NodalLoad:
    """``amplitude cos(harmonic w t + phase)`` [N] on a node set of the fundamental sector,
    spread evenly over its nodes, along ``direction``. On a cyclic body it travels with the
    engine order (sector s carries the phase ``harmonic EO s phi``): that is the cyclic model.
    Harmonic 0 is a static load. spread: "nodes", the same force on every node of the set;
    "area", in proportion to each node's tributary area on the surface the set is a face
    of (a uniform traction: the consistent nodal forces of linear faces)."""

    node_set: str
    direction: str | tuple[float, float, float]
    amplitude: float
    harmonic: int = 1
    phase: float = 0.0  # [rad]
    spread: str = "nodes"

    def __post_init__(self):
        if self.spread not in SPREADS:
            raise ValueError(f"loads.{self.node_set}.spread = {self.spread!r}: expected one of "
                             f"{list(SPREADS)}")
        object.__setattr__(self, "direction",
                           _direction(f"loads.{self.node_set}.direction", self.direction))
        _finite(f"loads.{self.node_set}.amplitude", self.amplitude)
        _finite(f"loads.{self.node_set}.phase", self.phase)
        if not (isinstance(self.harmonic, int) and self.harmonic >= 0):
            raise ValueError(f"loads.{self.node_set}.harmonic = {self.harmonic!r}: expected an "
                             "integer >= 0")


@dataclass(frozen=True)
class Output:
    """A response: the displacement of a node set (its mean) along a direction [m]."""

    name: str
    node_set: str
    direction: str | tuple[float, float, float]

    def __post_init__(self):
        object.__setattr__(self, "direction",
                           _direction(f"outputs.{self.name}.direction", self.direction))


@dataclass(frozen=True)
class AssemblySpec:
    """Everything the assembly stage needs besides the mesh and the reduced bodies.

    engine_order: EO of the excitation (harmonic n lives on ND n EO mod Ns).
    speed: rotation speed [rad/s] of the centrifugal load, or None to tie it to the
        excitation frequency (speed = w / EO) along a sweep.
    centrifugal: bodies whose centrifugal load enters (static, harmonic 0).
    mass_bodies: bodies whose mass the mass multiplier scales (the damper mass studies).
    static_anchor: the order-0 anchor of the pairs' mean tangential displacement, as a
        fraction of their kt (assemble.static_anchor); 0: none.
    """

    contacts: tuple[PatchFriction, ...]
    engine_order: int
    loads: tuple[NodalLoad, ...] = ()
    outputs: tuple[Output, ...] = ()
    speed: float | None = None
    centrifugal: tuple[str, ...] = ()
    mass_bodies: tuple[str, ...] = ()
    static_anchor: float = 1e-3

    def __post_init__(self):
        if not (isinstance(self.engine_order, int) and self.engine_order >= 1):
            raise ValueError(f"engine_order = {self.engine_order!r}: expected an integer >= 1")
        if self.speed is not None:
            _finite("speed", self.speed, nonneg=True)
        if not static_anchor_allowed(self.static_anchor):
            raise ValueError(f"static_anchor = {self.static_anchor!r}: expected "
                             f"{STATIC_ANCHOR_RULE}")
        names = [c.patch for c in self.contacts]
        if len(set(names)) != len(names):
            raise ValueError(f"contacts: a patch is named twice in {names}")
        outs = [o.name for o in self.outputs]
        if len(set(outs)) != len(outs):
            raise ValueError(f"outputs: names must be unique, got {outs}")
