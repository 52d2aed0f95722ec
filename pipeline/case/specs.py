"""Typed, frozen specs: what every analysis spec has (:class:`Analysis`: its name, its
``set``, the table as given; each type's own class is in its module of ``app.analyses``), a
family of curves, and the case's [harmonics], [solver], [[contacts]] and [[loads]]: each
key's default in one place.

A validated ``[[analysis]]`` table becomes the spec of its type (:func:`analysis`, with the
class its ``kinds.AnalysisKind`` names); runners take these, never the table. A key the
case leaves out has its default in its spec class and nowhere else: the validator reads it
(:func:`defaults`), the runner uses it, results.h5 records it beside the keys given
(:meth:`Analysis.record`) and the drawers read the record back (:func:`from_record`, which
also fills the defaults a file from an older version lacks). The README's Analyses table
holds the same keys and defaults (a test).

Units: frequencies rad/s, times s, motions m.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from microslip.fourier import Harmonics, default_samples
from microslip.solve.continuation import Settings
from microslip.solve.response import MEASURES  # noqa: F401 (the measures)
from microslip.solve.sampling import Distribution


@dataclass(frozen=True, kw_only=True)
class Family:
    """One curve per value of ``key`` (a dotted case key), or per table of ``sets``
    (then ``values`` are the curves' labels); ``label`` names the values in legends
    (default: the key)."""

    values: tuple[Any, ...]
    key: str = ""
    label: str = ""
    sets: tuple[Mapping[str, Any], ...] = ()

    @property
    def legend(self) -> str:
        return self.label or self.key


@dataclass(frozen=True, kw_only=True)
class Analysis:
    """What every analysis has: its ``name``, the case keys it overrides (``set``, dotted
    paths) and the reference text's figure it reproduces (``figure``, words shown on the
    results page). ``given``: the table as the case wrote it (what results.h5 shows)."""

    type: ClassVar[str]
    name: str
    set: Mapping[str, Any] = field(default_factory=dict)
    figure: str = ""
    given: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    def table(self) -> dict[str, Any]:
        """The resolved keys in TOML form (tuples as lists, a family as a table; keys
        without a value, such as ``outputs`` meaning every output, left out)."""
        out = {"type": self.type}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name != "given" and value is not None:
                out[f.name] = _toml(value)
        return out

    def record(self) -> dict[str, Any]:
        """The attributes of the analysis' group in results.h5: the keys as given, each
        other key's default, and the family (an empty table when there is none)."""
        return self.table() | dict(self.given) | {"family": self.given.get("family", {})}


def distribution(table: Mapping[str, Any]) -> Distribution:
    """The Distribution of a validated ``{family = ...}`` table."""
    (family, v), = table.items()
    if family == "uniform":
        return Distribution(family, float(v[0]), float(v[1]))
    if family == "normal":
        return Distribution(family, float(v["mean"]), float(v["sigma"]))
    return Distribution(family, float(v["median"]), float(v["sigma"]))


@dataclass(frozen=True, kw_only=True)
class HarmonicsTable:
    """[harmonics]: orders 0..``max`` or the ``orders`` given; ``samples`` per period
    (None: the default of the highest order, ``fourier.default_samples``)."""

    max: int = 1
    orders: tuple[int, ...] | None = None
    samples: int | None = None

    @classmethod
    def of(cls, table: Mapping[str, Any]) -> HarmonicsTable:
        """The spec of a validated [harmonics] table."""
        return cls(**{k: _typed(k, v) for k, v in table.items()})

    @property
    def all_orders(self) -> tuple[int, ...]:
        return self.orders if self.orders is not None else tuple(range(self.max + 1))

    def harmonics(self) -> Harmonics:
        orders = self.all_orders
        return Harmonics(list(orders), self.samples if self.samples is not None
                         else default_samples(max(orders)))


@dataclass(frozen=True, kw_only=True)
class SolverTable:
    """[solver]: the continuation settings (their defaults: ``continuation.Settings``),
    ``sub_sample``, the sub-sample corrections of the contact forces, and ``jacobian``, how
    Newton solves (``hbm.JACOBIANS``)."""

    settings: Settings = field(default_factory=Settings)
    sub_sample: bool = True
    jacobian: str = "auto"

    @classmethod
    def of(cls, table: Mapping[str, Any]) -> SolverTable:
        """The spec of a validated [solver] table."""
        given = {k: v for k, v in table.items() if k not in ("sub_sample", "jacobian")}
        return cls(settings=Settings(**given),
                   sub_sample=table.get("sub_sample", cls.sub_sample),
                   jacobian=table.get("jacobian", cls.jacobian))


@dataclass(frozen=True, kw_only=True)
class ContactTable:
    """What every [[contacts]] table has besides its law's keys (``laws.interface``): its
    ``name`` (default ``contact<i>``), its ``law`` and whether the model includes it."""

    name: str
    law: str
    enabled: bool = True

    @classmethod
    def of(cls, table: Mapping[str, Any], index: int) -> ContactTable:
        return cls(name=str(table.get("name", f"contact{index}")), law=table.get("law", ""),
                   enabled=table.get("enabled", cls.enabled))


@dataclass(frozen=True, kw_only=True)
class LoadTable:
    """A [[loads]] table: ``amplitude`` cos(``harmonic`` w t + ``phase``) [N, deg] on
    ``dof``; harmonic 0 is a static load."""

    dof: str
    amplitude: float
    harmonic: int = 1
    phase: float = 0.0

    @classmethod
    def of(cls, table: Mapping[str, Any]) -> LoadTable:
        return cls(**{k: table[k] for k in ("dof", "amplitude", "harmonic", "phase")
                      if k in table})


def keys(cls: type[Analysis]) -> set[str]:
    """The keys an analysis of spec class ``cls`` accepts."""
    return {"type"} | {f.name for f in dataclasses.fields(cls)} - {"given"}


def defaults(cls: type[Analysis]) -> dict[str, Any]:
    """{key: default} of an analysis spec class in TOML form (keys without a default, or
    whose default is "none", such as ``outputs``, left out)."""
    out = {}
    for f in dataclasses.fields(cls):
        if f.name == "given":
            continue
        if f.default is not dataclasses.MISSING and f.default is not None:
            out[f.name] = _toml(f.default)
        elif f.default_factory is not dataclasses.MISSING:
            out[f.name] = _toml(f.default_factory())
    return out


def analysis_name(table: Mapping[str, Any], index: int) -> str:
    """The name of the ``index``-th [[analysis]] table: its own, or ``analysis<index>``."""
    return str(table.get("name", f"analysis{index}"))


def analysis(table: Mapping[str, Any], cls: type[Analysis], index: int = 0) -> Analysis:
    """The spec (of class ``cls``, its type's) of a validated ``[[analysis]]`` table
    (``index``: its place, which names an unnamed analysis)."""
    values: dict[str, Any] = {"name": analysis_name(table, index),
                              "given": dict(table)}
    for f in dataclasses.fields(cls):
        if f.name in table and f.name not in ("name", "given"):
            values[f.name] = _typed(f.name, table[f.name], isinstance(f.default, tuple))
    return cls(**values)


def from_record(record: Mapping[str, Any], cls: type[Analysis]) -> Analysis:
    """The spec (of class ``cls``) of an analysis' record in results.h5
    (:meth:`Analysis.record`, read back as values: ``results.writer.attr_table``); the keys
    a file from an older version lacks take their defaults."""
    names = keys(cls) | {"name"}
    table = {k: v for k, v in record.items() if k in names}
    if not table.get("family"):
        table.pop("family", None)
    return analysis(table, cls)


# ------------------------------------------------------------------ conversion
def _typed(key: str, value: Any, plural: bool = True) -> Any:
    """A TOML value as the spec holds it: lists as tuples, a method as a tuple of
    methods where the spec takes several (``plural``), a family as a Family."""
    if key == "family":
        return Family(values=tuple(value["values"]), key=value.get("key", ""),
                      label=value.get("label", ""),
                      sets=tuple(dict(s) for s in value.get("sets", ())))
    if key == "method" and isinstance(value, str) and plural:
        return (value,)
    if key in ("set", "parameters"):
        return dict(value)
    if isinstance(value, list):
        return tuple(value)
    return value


def _toml(value: Any) -> Any:
    if isinstance(value, Family):
        return {k: _toml(v) for k, v in dataclasses.asdict(value).items()
                if v not in ("", ())}
    if isinstance(value, tuple):
        return [_toml(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _toml(v) for k, v in value.items()}
    return value


