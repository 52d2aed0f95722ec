"""The structural stage of a case: from the meshed geometry to the reduced model of every body
at every nodal diameter the case needs, and the contact stiffness of every patch, as the
[reduction] table asks (its keys and conventions: ``case.reduction_table``).

Reduced models are cached in ``<out>/models/cb-<hash>.h5``: a re-run reuses every body and ND
whose mesh, material, constraints, masters and mode selection have not changed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from numpy.typing import NDArray

from microslip.case import InputError
from microslip.case.reduction_table import (
    ReductionTable,
    body_specs,
    needed_nodal_diameters,
    patch_stiffnesses,
)
from microslip.fe import bodies, contact_stiffness, reduced_model
from microslip.fe.fem import InvertedElements
from microslip.fe.reduced_model import ReducedModel

from .progress import time_left

Progress = Callable[[str], None]


@dataclass
class StructureResult:
    """What the stage produced.

    models: body -> ND -> ReducedModel (a body without cyclic symmetry: the same model under
        every ND).
    patch_stiffness: contact patch -> PatchStiffness (kn, kt per node pair [N/m]).
    nodal_diameters: the NDs reduced; f_max: the case's f_max, or the one inferred for the
        non-cyclic bodies [Hz] (None: neither).
    cached: (body, ND) pairs that were read from the cache instead of reduced.
    files: (body, ND) -> the model's HDF5 file (with a cache directory).
    frequencies: (body, ND) -> the first ten natural frequencies of the reduced model (free
        masters) [Hz].
    """

    models: dict[str, dict[int, ReducedModel]]
    patch_stiffness: dict[str, contact_stiffness.PatchStiffness]
    nodal_diameters: tuple[int, ...]
    f_max: float | None
    cached: list[tuple[str, int]] = field(default_factory=list)
    seconds: dict[tuple[str, int], float] = field(default_factory=dict)
    files: dict[tuple[str, int], Path] = field(default_factory=dict)
    frequencies: dict[tuple[str, int], NDArray] = field(default_factory=dict)




def reduce_structure(mesh: Any, red: Mapping[str, Any] | ReductionTable,
                     cache_dir: str | Path | None,
                     case_orders: Iterable[int] | None = None, progress: Progress = print,
                     surfaces: bool = False) -> StructureResult:
    """Reduce every body of ``mesh`` for the NDs the [reduction] table asks (see the module).
    ``surfaces``: recover every body on its outer surface too (a case that draws deformed
    shapes; part of each model's cache key).

    Everything the table names (node sets, bodies, patches, NDs) is checked before the first
    assembly. Cyclic bodies go first; without f_max, the others get the highest 10th
    fixed-interface frequency of the cyclic bodies as theirs.
    """
    red = ReductionTable.of(red)
    try:  # (the mistuned body and its region are resolved on the mesh here)
        specs = body_specs(mesh, red, surfaces)
    except ValueError as err:
        raise InputError(str(err)) from None
    sectors = {b.sectors for b in mesh.cyclic.values()}
    if not sectors:
        nds: tuple[int, ...] = (0,)
    else:
        nds = needed_nodal_diameters(red, max(sectors), case_orders)
    for spec in specs:  # names and node sets, before any heavy work
        try:
            bodies.spec_nodes(mesh, spec)
        except ValueError as err:
            raise InputError(str(err)) from None
    patch_stiffness = patch_stiffnesses(mesh, specs, red)
    backend = red.factorization
    result = StructureResult({}, patch_stiffness, nds, red.f_max)
    count = _Count(sum(len(set(nds)) if s.body in mesh.cyclic else 1 for s in specs))
    for spec in sorted(specs, key=lambda s: s.body not in mesh.cyclic):  # cyclic bodies first
        is_cyclic = spec.body in mesh.cyclic
        if not is_cyclic and spec.f_max is None and spec.n_modes == "auto":
            f_ref = reduced_model.reference_frequency(
                m for models in result.models.values() for m in models.values())
            if f_ref is not None:
                result.f_max = f_ref
                spec = replace(spec, f_max=f_ref)

        report = _recorder(result, spec.body, None if is_cyclic else nds, progress, count)
        try:
            result.models[spec.body] = bodies.reduce_body(mesh, spec, nds, cache_dir,
                                                             backend, report)
        except InvertedElements as err:  # a deck's (or a mesher's) mid nodes
            raise InputError(f"body {spec.body!r}: {err}") from None
    return result


@dataclass
class _Count:
    """Models of the stage done so far, of ``total`` (one per cyclic body and ND, one per
    other body), for the progress lines; the time left is from the rate so far."""

    total: int
    clock: Callable[[], float] = time.perf_counter
    done: int = 0
    t0: float | None = None  # when the stage began (default: now)

    def __post_init__(self):
        if self.t0 is None:
            self.t0 = self.clock()

    def step(self) -> str:
        """One more model done: "i/N" and, while models remain, "~N s left"."""
        self.done += 1
        left = time_left(self.clock() - self.t0, self.done / max(self.total, 1))
        return f"{self.done}/{self.total}" + (f", {left}" if left else "")


def _recorder(result: StructureResult, body: str, serves: tuple[int, ...] | None,
              progress: Progress, count: _Count) -> Callable[..., None]:
    """The ``report`` of reduce_body for one body: records each model (under every ND in
    ``serves`` for a non-cyclic body, whose one model serves them all) and prints a line."""

    def report(h: int, model: ReducedModel, path: Path | None, cached: bool,
               seconds: float) -> None:
        nds = (h,) if serves is None else serves
        f = model.frequencies(10)
        result.seconds[body, nds[0]] = seconds
        if cached:
            result.cached.append((body, nds[0]))
        for nd in nds:
            result.frequencies[body, nd] = f
            if path is not None:
                result.files[body, nd] = path
        progress(f"[reduction] {body}" + (f" ND {h}" if serves is None else "")
                 + f" ({count.step()}): {model.n_masters} master DOFs + {model.n_modes} modes, "
                 + ("from cache" if cached else f"{seconds:.1f} s") + "; f [Hz] "
                 + " ".join(f"{x:.0f}" for x in f[:7]))

    return report
