"""A validated case: the case table as run, its analyses as typed specs, and copies with
keys overridden (validated again). :class:`CaseError` lists every fault found."""

from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from . import specs
from .faults import faults
from .geometry_table import GeometryTable
from .kinds import Kinds, kinds_or_shipped
from .mistuning_table import MistuningTable
from .paths import set_path
from .reduction_table import ReductionTable


class CaseError(ValueError):
    """All faults found in a case file, one per line."""

    def __init__(self, source: str, faults: list[str]):
        self.faults = faults
        if len(faults) == 1:  # one fault, one line
            super().__init__(f"{source}: {faults[0]}")
            return
        super().__init__(f"{source}: {len(faults)} faults\n" + "\n".join(
            f"  - {f}" for f in faults))


class InputError(ValueError):
    """A fault of a case found only once its mesh exists (what a parametric model's names
    resolve to, a declared contact's surfaces, a body's masters): one line, exit 2."""


@dataclass(frozen=True)
class Case:
    """A validated case: the raw table (as run) plus its content hash; ``renamed``: a note
    per table the file gives by an old name (``file.RENAMED``)."""

    data: dict
    source: str
    renamed: tuple[str, ...] = ()
    #: the analysis types it may name (None: the shipped ones, ``kinds.shipped``)
    kinds: Kinds | None = field(default=None, compare=False)

    @property
    def known_kinds(self) -> Kinds:
        """The analysis types this case's analyses are read and run by."""
        return kinds_or_shipped(self.kinds)

    @property
    def title(self) -> str:
        return self.data.get("title", Path(self.source).stem)

    @property
    def analyses(self) -> list[dict]:
        """The [[analysis]] tables as written."""
        return self.data.get("analysis", [])

    @cached_property
    def analysis_specs(self) -> tuple[specs.Analysis, ...]:
        """Each analysis as its typed spec, defaults resolved."""
        kinds = self.known_kinds
        return tuple(kinds.spec(a, i) for i, a in enumerate(self.analyses))

    @cached_property
    def harmonics_table(self) -> specs.HarmonicsTable:
        """[harmonics] as its spec, defaults resolved."""
        return specs.HarmonicsTable.of(self.data.get("harmonics", {}))

    @cached_property
    def solver_table(self) -> specs.SolverTable:
        """[solver] as its spec, defaults resolved."""
        return specs.SolverTable.of(self.data.get("solver", {}))

    @cached_property
    def geometry_table(self) -> GeometryTable:
        """[geometry] as its spec."""
        return GeometryTable.of(self.data["geometry"])

    @cached_property
    def reduction_table(self) -> ReductionTable:
        """[reduction] as its spec, defaults resolved."""
        return ReductionTable.of(self.data["reduction"], MistuningTable.of(
            (self.data.get("assembly") or {}).get("mistuning")))

    @property
    def draws_shapes(self) -> bool:
        """Whether an frf draws deformed shapes at its map points: then every body is
        recovered on its outer surface too."""
        kinds = self.known_kinds
        return any(kinds.of(a).surfaces(a) for a in self.analysis_specs)

    @property
    def dofs(self) -> list[str]:
        return list(self.data["model"]["dofs"])

    @property
    def content_hash(self) -> str:
        blob = json.dumps(self.data, sort_keys=True, default=str).encode()
        return hashlib.sha256(blob).hexdigest()

    def contacts_enabled(self) -> list[str]:
        """Names of the contacts the model includes, in order."""
        tables = (specs.ContactTable.of(c, i) for i, c in enumerate(self.data.get("contacts", [])))
        return [c.name for c in tables if c.enabled]

    def with_value(self, key: str, value: Any) -> Case:
        """A copy with one key set (dotted path; arrays of tables by name or index)."""
        return self.with_values({key: value})

    def with_values(self, values: dict[str, Any]) -> Case:
        """A copy with keys set; validated again (a value may break a rule)."""
        if not values:
            return self
        data = copy.deepcopy(self.data)
        for key, value in values.items():
            set_path(data, key, value, create=True)
        # no memory check: load bounded every analysis with its set and family already,
        # against the memory free then (a run's own arrays must not refuse its later curves)
        found: list[str] = []
        faults(data, found, kinds=self.kinds)
        if found:
            raise CaseError(self.source, found)
        return Case(data, self.source, self.renamed, self.kinds)
