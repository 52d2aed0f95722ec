"""The analysis types: one :class:`AnalysisKind` each, what a ``[[analysis]]`` table of that
``type`` is (its spec), how it is checked, estimated, planned, run and drawn.

The kinds a case knows are a :class:`Kinds` (immutable: ``with_kind`` makes a larger one).
The shipped kinds are the modules of :mod:`microslip.app.analyses`, one per type, found the
way plugins are (:func:`shipped`): the case layer checks and estimates through the kind's
own functions without importing the runners above it, and a kind from outside the package
runs through ``check``, ``run`` and ``render`` by joining a ``Kinds`` (``tests/
test_analysis_kinds.py``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from . import specs

#: Where the shipped kinds live: a module per analysis type, each with its ``KIND``.
SHIPPED = "microslip.app.analyses"


@dataclass(frozen=True)
class Checking:
    """What a kind's check sees of one ``[[analysis]]`` table.

    pre: the table's name in fault lines (``analysis.<name>``); table: its keys with every
    default filled in; given: its keys as written; data: the whole case; contacts: the
    names of its contacts; outputs: the DOFs (lumped) or named outputs (assembly) it may
    name; out: the fault lines (appended to)."""

    pre: str
    table: dict
    given: dict
    data: dict
    contacts: frozenset[str]
    outputs: frozenset[str]
    out: list[str]

    def fault(self, text: str) -> None:
        """One fault line, of this table."""
        self.out.append(f"{self.pre}{text}")


def no_surfaces(spec: specs.Analysis) -> bool:
    """An analysis that recovers no body's outer surface (the default of a kind)."""
    return False


@dataclass(frozen=True)
class AnalysisKind:
    """One analysis type.

    name: the ``type`` key; spec: its frozen spec class (``specs.Analysis``: its keys and
    defaults). check(checking): its own rules, after the common ones (keys known, ``set``).
    task_seconds(data, spec, variant): rough seconds of one task in one process (``case.
    estimate``); size(name, data, table): its ``estimate.Size`` (None: the harmonic
    balance's, from the case's contacts and harmonics). plan(case, spec, context): its dry
    run's stages (``app.plan``; None: one stage, never cached). run(case, spec, group, run)
    -> (status, message): computes it into its results group (``app.run``); draw(group,
    name, out, options) -> paths: its pictures from results.h5 alone (``draw``).
    kernels: it evaluates the contact laws (a first run compiles them); lumped, assembly,
    bodies: the cases it runs on (a lumped [model]; an [assembly]; reduced bodies without
    [assembly]); pictures_per_output: a picture per output of a lumped case; notes: the
    case's sampling notes concern it (a continuation of the balance); surfaces(spec):
    whether that analysis recovers every body's outer surface (its deformed shapes: the
    reduction then keeps the surface nodes)."""

    name: str
    spec: type[specs.Analysis]
    check: Callable[[Checking], None]
    task_seconds: Callable[[dict, Any, dict | None], float]
    run: Callable[..., tuple[str, str]]
    draw: Callable[..., list]
    size: Callable[[str, dict, dict], Any] | None = None
    plan: Callable[..., list] | None = None
    kernels: bool = False
    lumped: bool = True
    assembly: bool = False
    bodies: bool = False
    pictures_per_output: bool = False
    notes: bool = False
    surfaces: Callable[[Any], bool] = no_surfaces


class Kinds(Mapping[str, AnalysisKind]):
    """The analysis types a case may name, by name (immutable)."""

    def __init__(self, kinds: tuple[AnalysisKind, ...] = ()) -> None:
        self._kinds = {k.name: k for k in kinds}

    def __getitem__(self, name: str) -> AnalysisKind:
        return self._kinds[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._kinds)

    def __len__(self) -> int:
        return len(self._kinds)

    def __repr__(self) -> str:
        return f"Kinds({', '.join(self._kinds)})"

    def with_kind(self, kind: AnalysisKind) -> Kinds:
        """These kinds and ``kind`` (replacing one of its name)."""
        return Kinds((*(k for k in self._kinds.values() if k.name != kind.name), kind))

    def of(self, spec: specs.Analysis) -> AnalysisKind:
        """The kind of a spec."""
        return self._kinds[spec.type]

    def spec(self, table: Mapping[str, Any], index: int = 0) -> specs.Analysis:
        """The spec of a validated ``[[analysis]]`` table."""
        return specs.analysis(table, self._kinds[table["type"]].spec, index)


def kinds_or_shipped(kinds: Kinds | None) -> Kinds:
    """``kinds``, or the shipped ones when None."""
    return shipped() if kinds is None else kinds


@cache
def shipped() -> Kinds:
    """The analysis types this package ships: the ``KIND`` of every module of
    :data:`SHIPPED` (imported by name, once: the one place this stage reaches the runners,
    as a plugin host finds its plugins)."""
    return importlib.import_module(SHIPPED).KINDS
