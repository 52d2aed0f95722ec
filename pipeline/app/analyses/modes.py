"""``type = "modes"``: the lowest modes of every reduced body, unreduced (held as its
reduction holds it) against its reduced model, per nodal diameter; on an assembly case also
the reduced assembly's, every contact stuck and free (the linear limits' resonances)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import ClassVar

import h5py
import numpy as np

from microslip.case import Case, operating_point
from microslip.case.checks import is_int
from microslip.case.estimate import Size
from microslip.case.kinds import AnalysisKind, Checking
from microslip.case.specs import Analysis
from microslip.draw import pictures
from microslip.results import schema

from ..models import AssemblyModels
from ..plan import PlanContext, Stage, modes_stage
from ..running import Run, draw_analysis


@dataclass(frozen=True, kw_only=True)
class Modes(Analysis):
    """The lowest ``count`` natural frequencies of every body of a reduced case, unreduced
    (held as the reduction holds it, at each nodal diameter reduced) and reduced (its
    Craig-Bampton model, masters free), and the reduction's error on each; ``shapes``: the
    unreduced mode shapes kept in results.h5 (vertex displacements)."""

    type: ClassVar[str] = "modes"
    count: int = 10
    shapes: bool = True


#: modes per body and nodal diameter at most (a modal answer, not a spectrum)
MAX_MODES = 200


def check(c: Checking) -> None:
    """Reduced bodies to take the modes of, a count within MAX_MODES, the shapes flag."""
    a, pre = c.table, c.pre
    if "reduction" not in c.data:
        c.out.append(f"{pre}: the modes of reduced bodies need [geometry] and [reduction]")
    if not (is_int(a["count"]) and 1 <= a["count"] <= MAX_MODES):
        c.out.append(f"{pre}.count = {a['count']!r}: expected an integer in [1, "
                     f"{MAX_MODES}] (modes per body and nodal diameter)")
    if not isinstance(a["shapes"], bool):
        c.out.append(f"{pre}.shapes = {a['shapes']!r}: expected true or false (keep the "
                     "mode shapes in results.h5)")


def seconds(data: dict, spec: Modes, variant: dict | None = None) -> float:
    """Not a task: the bodies' eigen-solves (:func:`plan` scales the reduction's)."""
    return 0.0


def size(name: str, data: dict, table: dict) -> Size:
    """Sparse factorizations like the reduction's, no balance."""
    return Size(name, 0, 0, "eigen-solves of the unreduced bodies")


def plan(case: Case, spec: Modes, context: PlanContext) -> list[Stage]:
    """A share of the reduction's work, every run."""
    from microslip.case.estimate import analysis_seconds

    return [modes_stage(spec, context, analysis_seconds(case.data, spec, case.known_kinds))]


def run_modes(case: Case, spec: Modes, group: h5py.Group, run: Run) -> tuple[str, str]:
    """The lowest modes of every reduced body, unreduced (held as its reduction holds it)
    and reduced, per nodal diameter (``fe.body_modes``): results.h5 <name>/<body>/nd<h> (a body
    without cyclic symmetry: <body>/body) and the picture of the reduction's error."""
    from microslip.case.reduction_table import body_specs
    from microslip.fe import fem
    from microslip.fe.body_modes import body_modes

    mesh, result = run.structure
    red = case.reduction_table
    bodies = {b.body: b for b in body_specs(mesh, red)}
    worst = 0.0
    for name, models in result.models.items():
        body = bodies[name]
        assembled = fem.assemble(mesh, name, body.material, body.order)
        is_cyclic = name in mesh.cyclic
        parent = group.create_group(name)
        for h, model in (models.items() if is_cyclic else list(models.items())[:1]):
            t = time.perf_counter()
            found = body_modes(mesh, body, model, spec.count, h if is_cyclic else None,
                               spec.shapes, red.factorization, assembled)
            error = found.relative_error
            worst = max(worst, float(np.abs(error).max(initial=0.0)))
            data = {"frequencies_hz": found.frequencies_hz, "reduced_hz": found.reduced_hz,
                    "relative_error": error, "nodes": found.nodes}
            if found.shapes is not None:
                data["shapes"] = found.shapes.astype(np.complex64 if np.iscomplexobj(
                    found.shapes) else np.float32)
            where = schema.nodal_diameter(h) if is_cyclic else "body"
            run.writer.write_group(parent, where, data, {
                "n_free": found.n_free, "seconds": time.perf_counter() - t,
                "reduced_modes": model.n_modes, "master_dofs": 3 * len(model.master_nodes)})
            run.progress(f"[{spec.name}] {name}" + (f" ND {h}" if is_cyclic else "")
                         + f" ({found.n_free} DOFs, {time.perf_counter() - t:.1f} s): f [Hz] "
                         + " ".join(f"{x:.6g}" for x in found.frequencies_hz[:6])
                         + f"; reduced model's error at most "
                         f"{float(np.abs(error).max(initial=0.0)):.2g}")
    if isinstance(run.models, AssemblyModels):
        _assembly_modes(case, spec, group, run)
    draw_analysis(pictures.modes, group, spec, run)
    return "complete", f"(the reduced models' frequency error at most {worst:.2g})"


def _assembly_modes(case: Case, spec: Modes, group: h5py.Group, run: Run) -> None:
    """The reduced assembly's natural frequencies on each dynamic harmonic's nodal diameter,
    every contact stuck and the cyclic bodies free of contact (the FRF's linear limits'
    resonances): results.h5 <name>/assembly/order<n>."""
    variant = case.with_values(spec.set)
    cm = run.models.assembly(variant)
    point = operating_point(variant)
    parent = group.create_group(schema.ASSEMBLY_MODES)
    for order in (o for o in cm.hb.harmonics.orders if o > 0):
        stuck, free = (cm.linear_frequencies(point, order, springs, spec.count)
                       for springs in ("stuck", "free"))
        run.writer.write_group(parent, f"order{order}", {"stuck_hz": stuck, "free_hz": free},
                               {"order": order})
        run.progress(f"[{spec.name}] assembly, harmonic {order}: stuck f [Hz] "
                     + " ".join(f"{x:.6g}" for x in stuck[:6]) + "; free (no contact) "
                     + " ".join(f"{x:.6g}" for x in free[:6]))


KIND = AnalysisKind("modes", Modes, check, seconds, run_modes, pictures.modes, size=size,
                    plan=plan, assembly=True, bodies=True)
