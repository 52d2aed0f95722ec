"""The stages before the analyses: the mesh of a case's [geometry] (read, or built and kept
in the shared cache; written with its previews) and the reduced models of its [reduction]
(their summary in results.h5)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

from microslip.case import Case, GeometryTable, InputError, harmonics
from microslip.case.geometry_table import contents_lines
from microslip.case.units import case_unit_lines
from microslip.draw.files import written
from microslip.draw.maps import EDGES
from microslip.geometry.boundaries import AveragedContact, SurfaceContact
from microslip.geometry.pairing import paired_contact
from microslip.results import schema
from microslip.results.writer import ResultsWriter

from .cache import SharedCache, built_mesh
from .running import Progress, StageFailed

if TYPE_CHECKING:
    from .structure import StructureResult


def mesh_geometry(table: GeometryTable, out: Path, progress: Progress = print,
                  pictures: bool = True, cache: SharedCache | None = None):
    """Build (or read) the [geometry] of a case, a parametric model's mesh kept in the
    shared ``cache``; write mesh.msh, mesh.vtu and (``pictures``) the previews (``microslip
    mesh``: no results file; a run draws them from results.h5)."""
    t = time.perf_counter()
    try:
        m, kept = built_mesh(table, cache)
    except ValueError as err:  # a declared contact on a model known only once meshed
        raise InputError(str(err)) from None
    elapsed = time.perf_counter() - t
    with written(out / "mesh.msh") as tmp:  # whole or not at all (a full disk)
        m.write_msh(tmp)
    with written(out / "mesh.vtu") as tmp:
        m.write(tmp)
    source = (f"{table.file} ({table.units})" if table.imported else m.model)
    where = f" from the shared cache ({kept.parent})" if kept else ""
    progress(f"[geometry] {source}: {m.points.shape[0]} nodes, {m.element_summary()}, "
             f"bodies {sorted(m.bodies)}, cyclic {sorted(m.cyclic)}, contacts "
             f"{sorted(m.contacts)} in {elapsed:.2f} s{where}; hash {m.content_hash[:12]}")
    for name, c in sorted(m.contacts.items()):
        dropped = (paired_contact(m, name).dropped
                   if isinstance(c, SurfaceContact | AveragedContact) else (0,))
        if dropped[0]:
            progress(f"[geometry] note: contact {name}: {dropped[0]} node(s) of {c.set_a} lie "
                     f"beyond {c.set_b} (up to {dropped[1]:.3g} m) and touch nothing (trim the "
                     "set, or raise the contact's tolerance if they should touch)")
    report = table.read().report if table.imported else None
    if table.imported:
        for line in contents_lines(m):
            progress(f"[geometry] {line}")
    if report is not None and report.skipped:
        progress("[geometry] note: not solids, so not part of the model (their nodes are node "
                 "sets): " + ", ".join(f"{n} {t}" for t, n in sorted(report.skipped.items())))
    if report is not None and report.dropped_sets:
        progress("[geometry] note: node sets of mid-side nodes only, so empty on the corner "
                 "mesh (name corner nodes instead): " + ", ".join(report.dropped_sets))
    if report is not None and report.curved_edges:
        progress(f"[geometry] {report.curved_edges} curved edges kept as the file has them "
                 f"(mid-edge nodes up to {100 * report.midnode_offset:.2g} % of an edge off "
                 "straight)")
    if pictures:
        from microslip.draw.previews import MeshView

        draw_previews(MeshView.from_mesh(m), m.content_hash, out, progress)
    return m


def say_units(data: dict, progress: Progress) -> None:
    """The unit an imported mesh was read in when the case gives none, and a warning per
    body implausible in its units (``case.units``)."""
    notes, warnings = case_unit_lines(data)
    for line in notes:
        progress(f"[geometry] note: {line}")
    for line in warnings:
        progress(f"warning: [geometry] {line}")


def draw_previews(source, content_hash: str, out: Path, progress: Progress = print) -> None:
    """The mesh previews of ``source`` (a results file being written, or a
    ``previews.MeshView``), unless those of the same mesh (``content_hash``) are there."""
    from microslip.draw.previews import MeshView, preview_names, render_previews

    view = source if isinstance(source, MeshView) else MeshView.from_results(source)
    stamp = out / "cache" / "previews.hash"  # the mesh the previews show
    names = [out / name for name in preview_names(view)]
    if stamp.is_file() and stamp.read_text() == content_hash and all(
            p.is_file() for p in names):
        progress(f"[geometry] previews unchanged ({', '.join(p.name for p in names)})")
        return
    for path in render_previews(view, out):
        progress(f"[geometry] wrote {path}")
    stamp.parent.mkdir(parents=True, exist_ok=True)
    stamp.write_text(content_hash)


def write_mesh(writer: ResultsWriter, mesh, elapsed: float) -> None:
    """/geometry (attrs: the model, its sizes and names; /geometry/cyclic/<body>: the cyclic
    faces' node positions), /surfaces (every body's outer surface) and /contact_grids:
    what the previews, maps and shapes are drawn on."""
    from microslip.draw.previews import MeshView

    view = MeshView.from_mesh(mesh)  # each body's surface found once
    writer.write_group(writer.file, schema.GEOMETRY, {schema.CYCLIC: view.cyclic_datasets()}, {
        "model": mesh.model, "content_hash": mesh.content_hash, "nodes": mesh.points.shape[0],
        "elements": mesh.element_summary(), "bodies": sorted(mesh.bodies),
        "contacts": sorted(mesh.contacts), "parameters": mesh.parameters,
        "status": "complete", "elapsed_s": elapsed, "type": "geometry"})
    write_contact_grids(writer, mesh)
    sectors = min((c.sectors for c in view.cyclic), default=0)
    writer.write_group(writer.file, schema.SURFACES, view.surface_datasets(),
                       {"sectors": sectors})


def write_contact_grids(writer: ResultsWriter, mesh) -> None:
    """/contact_grids/<patch>: each patch's node grid, frame and map orientation
    (maps.PatchGrid), what the maps are drawn on."""
    from microslip.draw.maps import PatchGrid

    for name in sorted(mesh.contacts):
        grid = PatchGrid.from_mesh(mesh, name)
        patch = mesh.contacts[name]
        writer.write_group(writer.file.require_group(schema.CONTACT_GRIDS), name,
                           grid.datasets() | {"points_b": mesh.points[grid.nodes_b]},
                           {"body_a": grid.body_a, "body_b": grid.body_b,
                            "high_edge": grid.high_edge,
                            "high_edge_name": EDGES[grid.high_edge] if grid.structured
                            else "", "b_sector_offset": int(patch.b_sector_offset)})


def write_structure(writer: ResultsWriter, mesh, case: Case, out: Path,
                    progress: Progress = print, cache: SharedCache | None = None
                    ) -> StructureResult:
    """The [reduction] stage: reduced models in the shared ``cache`` (reused when
    unchanged, by any run; None: kept nowhere) and their summary in results.h5
    /reduction/<body>/nd<h> (frequencies of the reduced model with free masters,
    fixed-interface mode frequencies, master nodes; attrs: model file name in the cache,
    sizes) and /reduction/contact_stiffness/<patch> (kn, kt per node pair [N/m])."""
    from microslip.fe.bodies import ReductionError

    from .structure import reduce_structure  # imports the FE stages only when needed

    t = time.perf_counter()
    orders = harmonics(case).orders if "harmonics" in case.data else None
    shapes = case.draws_shapes
    try:
        result = reduce_structure(mesh, case.reduction_table,
                                  cache.models if cache is not None else None, orders,
                                  progress, surfaces=shapes)
    except ReductionError as err:
        raise StageFailed(str(err)) from err
    if cache is not None:  # the least recently used beyond the bound go, never these
        cache.used(result.files.values())
        cache.prune(keep=result.files.values())
    datasets: dict = {body: {schema.nodal_diameter(h): {
        "frequencies_hz": result.frequencies[body, h], "mode_frequencies_hz": m.mode_frequencies,
        "master_nodes": m.master_nodes} for h, m in models.items()}
        for body, models in result.models.items()}
    datasets[schema.CONTACT_STIFFNESS] = {
        name: {"normal_n_per_m": s.normal, "tangential_n_per_m": s.tangential}
        for name, s in result.patch_stiffness.items()}
    writer.write_group(writer.file, schema.REDUCTION, datasets, {
        "nodal_diameters": list(result.nodal_diameters), "status": "complete",
        "f_max_hz": -1.0 if result.f_max is None else result.f_max,
        "cached": [f"{b} ND {h}" for b, h in result.cached], "type": "reduction",
        "elapsed_s": time.perf_counter() - t})
    for body, models in result.models.items():
        for h, m in models.items():
            attrs = writer.file[schema.REDUCTION][body][schema.nodal_diameter(h)].attrs
            attrs["n_modes"], attrs["n_master_dofs"] = m.n_modes, m.n_masters
            path = result.files.get((body, h))
            attrs["file"] = "" if path is None else path.name
    where = f" ({cache.models})" if cache is not None else ""
    progress(f"[reduction] {len(result.cached)} of {len(result.seconds)} models from the "
             f"shared cache{where}; stage {time.perf_counter() - t:.1f} s")
    return result
