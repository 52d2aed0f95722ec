"""The models a case's analyses solve: the lumped one its [model] writes, or the assembly
one of its [geometry], [reduction] and [assembly] tables. Both answer the same three
questions, so the runners need not know which they have."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any

import numpy as np

from microslip.case import Case, assembly_table, harmonics, lumped_model
from microslip.case.mistuning_table import MistuningTable
from microslip.solve.hbm import HarmonicBalance

if TYPE_CHECKING:
    from microslip.assembly.recovery import AssemblyModel


class LumpedModels:
    """A [model] case: its DOFs are its outputs."""

    def model(self, case: Case) -> HarmonicBalance:
        return lumped_model(case)

    def names(self, case: Case) -> list[str]:
        return case.dofs

    def expanded(self, case: Case, names: list[str]) -> list[str]:
        """The curves the named outputs make: one each."""
        return names

    def selection(self, case: Case, names: list[str]) -> list[int]:
        """DOF indices (what Response.coefficients and peak_curve take)."""
        return [case.dofs.index(n) for n in names]


#: Assembly models kept for reuse: each holds up to solve.hbm.CACHE_LIMIT (512 MB) of
#: per-point results, and a study that changes the contacts per curve (an uncertainty
#: sample) never meets one again; a case's base and one variant of it (blisk_damper's
#: light damper) are what a run reuses. (8 grew a worker to 3.7 GB over 4 samples.)
KEPT_ASSEMBLIES = 2


class AssemblyModels:
    """A [assembly] case: the mesh and reduced bodies are built once; each variant of the
    case (an analysis' ``set``, a family value) gets its assembly model, kept while its
    assembly (but for the mass and excitation multipliers), harmonics and solver tables are
    unchanged."""

    def __init__(self, mesh: Any, structure: Any):
        self.mesh = mesh
        self.structure = structure
        self._built: dict[str, AssemblyModel] = {}
        self._surfaces: dict[str, Any] | None = None
        self._disk: tuple[Any, Any] | None = None  # (full disk's mesh, TunedDisk): mistuned

    def surfaces(self) -> dict[str, Any]:
        """Per body its outer-surface nodes (``solutions.surfaces``), found once per run:
        where the shapes at every curve's map points are recovered."""
        if self._surfaces is None:
            from .solutions import surfaces

            self._surfaces = surfaces(self.mesh)
        return self._surfaces

    def assembly(self, case: Case) -> AssemblyModel:
        from microslip.assembly.join import join  # the FE stages, when needed

        # the mass and excitation multipliers enter per operating point (hb.linear's mass
        # part, the loads' scale): a damper mass study or excitation levels share one model
        table = {k: case.data.get(k) for k in ("assembly", "harmonics", "solver")}
        table["assembly"] = {k: v for k, v in (table["assembly"] or {}).items()
                             if k not in ("mass_multiplier", "excitation")}
        key = json.dumps(table, sort_keys=True, default=str)
        if key not in self._built:
            if len(self._built) >= KEPT_ASSEMBLIES:
                self._built.pop(next(iter(self._built)))
            mesh, models = self.mesh, self.structure.models
            stiffness = self.structure.patch_stiffness
            spec = assembly_table.spec(case.data, tuple(sorted(mesh.bodies)),
                                       tuple(mesh.cyclic))
            mistuning = self._mistuning(case)
            if mistuning is not None:
                disk = self._whole_disk(spec, mistuning)
                mesh, models, stiffness, spec = (disk.mesh, disk.bodies, disk.patch_stiffness,
                                                 disk.spec)
            self._built[key] = join(
                mesh, models, stiffness, spec, harmonics(case),
                sub_sample=case.solver_table.sub_sample, jacobian=case.solver_table.jacobian)
        return self._built[key]

    def _mistuning(self, case: Case) -> Any:
        """The case's Mistuning (None: a cyclic case)."""
        table = MistuningTable.of((case.data.get("assembly") or {}).get("mistuning"))
        if table is None:
            return None
        from microslip.assembly.mistuned import Mistuning
        from microslip.geometry.full_disk import sector_count

        return Mistuning(table.body_of(tuple(self.mesh.cyclic), tuple(self.mesh.bodies)),
                         table.deviations(sector_count(self.mesh)))

    def _whole_disk(self, spec: Any, mistuning: Any) -> Any:
        """The whole disk's bodies, patches and spec with a pattern (the full disk's mesh
        and the tuned annulus formed once per run: a pattern changes one stiffness)."""
        from microslip.assembly.mistuned import TunedDisk, whole_disk
        from microslip.geometry.full_disk import full_disk

        if self._disk is None:
            self._disk = (full_disk(self.mesh), TunedDisk.of(self.mesh, self.structure.models))
        full, tuned = self._disk
        return whole_disk(tuned, full, self.structure.patch_stiffness, spec, mistuning)

    def model(self, case: Case) -> HarmonicBalance:
        return self.assembly(case).hb

    def names(self, case: Case) -> list[str]:
        return self.expanded(case, assembly_table.output_names(case.data))

    def expanded(self, case: Case, names: list[str]) -> list[str]:
        """The curves the named outputs make: one each, or, on the whole disk, one per
        blade ("<name>#s")."""
        if MistuningTable.of((case.data.get("assembly") or {}).get("mistuning")) is None:
            return names
        from microslip.assembly.mistuned import blade_outputs
        from microslip.geometry.full_disk import sector_count

        return blade_outputs(names, sector_count(self.mesh))

    def selection(self, case: Case, names: list[str]) -> np.ndarray:
        """(n_outputs, n_dof) rows of the named outputs over the shared DOFs."""
        rows = self.assembly(case).outputs
        return np.array([rows[n] for n in names])
