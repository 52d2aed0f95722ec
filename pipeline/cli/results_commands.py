"""Commands on a results folder: ``show``, ``render``, ``report``, ``compare``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from microslip.cli.shared import output_folder


def show(argv: list[str]) -> int:
    """Summarise a results file (or the results.h5 of an output folder)."""
    from microslip.results.writer import ResultsError, leftover, summary

    parser = argparse.ArgumentParser(prog="microslip show", description=show.__doc__)
    parser.add_argument("path", type=Path, help="results.h5 or its folder")
    args = parser.parse_args(argv)
    if not args.path.exists():
        print(f"microslip show: {args.path}: no such file or folder", file=sys.stderr)
        return 2
    target = args.path / "results.h5" if args.path.is_dir() else args.path
    tmp = target.with_name(target.name + ".tmp")  # what a killed run leaves
    if not target.is_file():
        if not tmp.is_file():
            print(f"microslip show: no results file at {target}", file=sys.stderr)
            return 2
        print(leftover(tmp))
        print(f"microslip show: no {target.name} in {target.parent}, only the leftover "
              f"{tmp.name} of an unfinished run (above)", file=sys.stderr)
        return 1
    try:
        print(summary(target))
    except ResultsError as err:
        print(f"microslip show: {err}", file=sys.stderr)
        return 2
    if tmp.is_file():
        print(f"note: {leftover(tmp)}")
    return 0


def _render_options(args) -> tuple[object, list[str]]:
    """The pictures.Options of `render`'s arguments, and one line per bad one."""
    from matplotlib.colors import is_color_like

    from microslip.app.analyses.frf import MAP_TYPES
    from microslip.draw import maps, pictures
    from microslip.laws.states import STATE_NAMES

    faults: list[str] = []
    colours = dict(maps.STATE_COLOURS)
    for item in args.colour:
        state, _, colour = item.partition("=")
        if state not in STATE_NAMES:
            faults.append(f"--colour {item}: {state!r} is not a state; states: "
                          f"{list(STATE_NAMES)}")
        elif not is_color_like(colour):
            faults.append(f"--colour {item}: {colour!r} is not a colour (a name like 'gold' "
                          "or #rrggbb)")
        else:
            colours[STATE_NAMES.index(state)] = colour
    panel = maps.PANEL
    if args.size is not None:
        w, _, h = args.size.partition("x")
        if not (w.isdigit() and h.isdigit() and 100 <= int(w) <= 4000
                and 100 <= int(h) <= 4000):
            faults.append(f"--size {args.size}: expected WIDTHxHEIGHT in pixels of one map, "
                          "each 100..4000 (e.g. 800x600)")
        else:
            panel = (int(w), int(h))
    kinds = None
    if args.maps is not None:
        kinds = tuple(k for k in args.maps.split(",") if k)
        bad = [k for k in kinds if k not in MAP_TYPES]
        if bad:
            faults.append(f"--maps {args.maps}: {bad} not among {list(MAP_TYPES)}")
    return pictures.Options(colours, panel, args.at, kinds), faults


def render(argv: list[str]) -> int:
    """Redraw the pictures of a results folder from its results.h5 alone (FRFs, peak
    curves, contact-status and static-load maps, deformed shapes): other colours, another
    point, another size. Nothing is recomputed."""
    from microslip.draw import pictures
    from microslip.results.writer import ResultsError

    parser = argparse.ArgumentParser(prog="microslip render", description=render.__doc__)
    parser.add_argument("path", type=Path, help="results folder (or its results.h5)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder of the pictures (default: the results folder)")
    parser.add_argument("--at", type=float, default=None, metavar="VALUE",
                        help="draw the maps at the computed point nearest this parameter "
                        "value (rad/s for a frequency sweep) of every curve (deformed "
                        "shapes exist at the case's own map points only)")
    parser.add_argument("--size", default=None, metavar="WxH",
                        help=f"pixels of one map or shape panel (default {maps_panel()})")
    parser.add_argument("--colour", action="append", default=[], metavar="STATE=COLOUR",
                        help="colour of a contact state in the status maps, e.g. "
                        "'open=gold' or 'stick-slip=#777777' (repeatable)")
    parser.add_argument("--maps", default=None, metavar="TYPES",
                        help="which maps: status, normal_load, shape (deformed sector and "
                        "full disk), comma-separated (default: the case's)")
    parser.add_argument("--analysis", action="append", default=None, metavar="NAME",
                        help="only this analysis (repeatable)")
    args = parser.parse_args(argv)
    target = args.path / "results.h5" if args.path.is_dir() else args.path
    if not target.is_file():
        print(f"microslip render: no results file at {target}", file=sys.stderr)
        return 2
    options, faults = _render_options(args)
    try:
        faults += _analysis_faults(target, args.analysis)
    except ResultsError as err:
        print(f"microslip render: {err}", file=sys.stderr)
        return 2
    if faults:
        print("\n".join(f"microslip render: {f}" for f in faults), file=sys.stderr)
        return 2
    out = args.out or target.parent
    if not output_folder("render", out, args.out is not None):
        return 2
    try:
        paths = pictures.render(target, out, options, args.analysis)
    except ResultsError as err:
        print(f"microslip render: {err}", file=sys.stderr)
        return 2
    for p in paths:
        print(f"wrote {p}")
    if not paths:
        print(f"microslip render: {target} has no analysis with pictures to redraw"
              + (f" among {args.analysis}" if args.analysis else ""), file=sys.stderr)
        return 1
    return 0


def _analysis_faults(target: Path, names: list[str] | None) -> list[str]:
    """A line per ``--analysis`` NAME the results file does not hold."""
    from microslip.results.writer import analysis_names

    if not names:
        return []
    held = analysis_names(target)
    return [f"--analysis {n}: {target} has no analysis of that name; its analyses: {held}"
            for n in names if n not in held]


def maps_panel() -> str:
    from microslip.draw import maps, shapes

    return (f"{maps.PANEL[0]}x{maps.PANEL[1]} per map, {shapes.PANEL[0]}x{shapes.PANEL[1]} "
            "per shape panel")


def compare(argv: list[str]) -> int:
    """Compare two results files (or folders) dataset by dataset: exit 0 when every number
    agrees to --rtol, 1 when some differ (listed)."""
    from microslip.results.compare import report, results_path
    from microslip.results.writer import ResultsError, open_results

    parser = argparse.ArgumentParser(prog="microslip compare", description=compare.__doc__)
    parser.add_argument("old", type=Path, help="results.h5 or the output folder holding it")
    parser.add_argument("new", type=Path, help="results.h5 or the output folder holding it")
    parser.add_argument("--rtol", type=float, default=1e-12,
                        help="largest difference of a dataset, relative to its largest "
                        "entry (default 1e-12)")
    args = parser.parse_args(argv)
    if not (np.isfinite(args.rtol) and args.rtol >= 0):
        print(f"microslip compare: --rtol = {args.rtol}: expected a number >= 0",
              file=sys.stderr)
        return 2
    for given in (args.old, args.new):
        if not results_path(given).is_file():
            print(f"microslip compare: no results file at {results_path(given)}",
                  file=sys.stderr)
            return 2
        try:  # a file that is not a results file is bad input, not a difference
            open_results(results_path(given)).close()
        except ResultsError as err:
            print(f"microslip compare: {err}", file=sys.stderr)
            return 2
    try:
        same, text = report(args.old, args.new, args.rtol)
    except OSError as err:
        print(f"microslip compare: cannot read a results file: {err}", file=sys.stderr)
        return 2
    print(text)
    return 0 if same else 1


def report(argv: list[str]) -> int:
    """Write a results folder's page, report.html: one self-contained HTML file drawn from
    results.h5 (``--index OUT``: an index page linking the pages of several folders, in the
    order given: a course)."""
    from microslip.report import write_index, write_report

    parser = argparse.ArgumentParser(prog="microslip report", description=report.__doc__)
    parser.add_argument("folders", type=Path, nargs="+", help="results folder(s) (or "
                        "results.h5)")
    parser.add_argument("--index", type=Path, default=None, metavar="OUT",
                        help="also write an index page (OUT.html, or OUT/index.html) "
                        "linking every folder's page")
    args = parser.parse_args(argv)
    absent = [p for p in args.folders if not p.exists()]
    if absent:
        print(f"microslip report: {absent[0]}: no such file or folder", file=sys.stderr)
        return 2
    for folder in args.folders:
        print(f"wrote {write_report(folder)}")
    if args.index is not None:
        folders = [p if p.is_dir() else p.parent for p in args.folders]
        print(f"wrote {write_index(folders, args.index)}")
    return 0
