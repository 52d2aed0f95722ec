"""The page of one results file: ``report.html`` beside it, one self-contained file (the
pictures inlined as PNG data, the style and the plot's script inlined: it opens offline
by double-click). Drawn from results.h5 alone: the pictures are drawn again from it, the
numbers read from it. A missing, unreadable or partial results file gives a page saying
what is missing, not a traceback."""

from __future__ import annotations

import base64
import json
import tempfile
from html import escape
from importlib.resources import files
from pathlib import Path

import h5py

from microslip.draw.files import written
from microslip.draw.pictures import Options, analysis_spec, curves
from microslip.results.writer import NOT_ANALYSES, ResultsError, attr_text, open_results

from .captions import caption
from .interactive import frf_plots
from .numbers import Table, reduction_tables, tables

#: the page's file name in the results folder
REPORT = "report.html"

#: what each analysis type computes, in a sentence
ABOUT = {
    "frf": "Forced response by the multi-harmonic balance with the coupled static/dynamic "
           "contact problem, continued in the swept parameter (Firrone & Zucca sections 4 "
           "and 7).",
    "peak": "The resonance peak followed against a parameter: the performance curve "
            "against the excitation, the optimization curve against a preload or a mass "
            "(Firrone & Zucca Figs. 6 and 22).",
    "loops": "Hysteresis loops of one contact under a prescribed relative motion (Firrone & "
             "Zucca section 3): the force against the displacement over a cycle.",
    "dti": "Direct time integration to the steady state at chosen frequencies, against the "
           "harmonic balance: the independent check of the balance.",
    "transient": "The response from rest, integrated in time.",
    "uncertainty": "The resonance peak over samples of uncertain inputs: its percentiles, "
                   "the probability of exceeding a limit, and which input matters.",
    "nonlinear_modes": "Nonlinear modes (extended periodic motion concept): the natural "
                       "frequency and damping ratio against the vibration level, and the "
                       "resonance peaks synthesized from them.",
    "modes": "Modes of the reduced bodies against the unreduced ones: the reduction's "
             "accuracy.",
}

STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0 auto;
max-width:980px;padding:12px 18px 40px;color:#222;line-height:1.45}
h1{font-size:1.55em;margin:.4em 0}h2{font-size:1.25em;margin-top:1.8em;border-bottom:1px solid
#ccc}h2 small{color:#666;font-weight:normal}
.status{display:inline-block;padding:2px 10px;border-radius:10px;font-weight:bold}
.status-complete{background:#d8f0d8}.status-partial,.status-stopped{background:#fbe6c2}
.status-failed,.status-interrupted,.status-missing{background:#f6c9c9}
.warn{background:#fff4d6;border-left:4px solid #e0a000;padding:6px 10px;margin:8px 0}
.missing{background:#fde8e8;border-left:4px solid #c33;padding:6px 10px;margin:8px 0}
figure{margin:14px 0}figure img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.92em;color:#444}
table{border-collapse:collapse;margin:8px 0;font-size:.92em;display:block;overflow-x:auto}
th,td{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f3f3f3}
td:first-child,th:first-child{text-align:left}
pre{white-space:pre-wrap;background:#f7f7f7;padding:8px}
.ms-plot{position:relative;margin:12px 0}.ms-svg{width:100%;height:auto;font-size:12px;
user-select:none}.ms-frame{fill:none;stroke:#999}.ms-grid{stroke:#eee}
.ms-title{font-weight:bold}.ms-mark{font-weight:bold;font-size:13px}
.ms-link{fill:#1050c0;cursor:pointer;text-decoration:underline}
.ms-band{fill:rgba(30,120,220,.12);stroke:#1e78dc}
.ms-tip{display:none;position:absolute;background:#fff;border:1px solid #888;padding:4px 8px;
font-size:12px;pointer-events:none;box-shadow:0 1px 4px rgba(0,0,0,.2);z-index:2}
.ms-legend{font-size:12px}.ms-legend label{margin-right:12px;white-space:nowrap}
.ms-swatch{display:inline-block;width:14px;height:3px;margin:0 4px 3px 2px}
footer{margin-top:2em;font-size:.85em;color:#666}
"""


def write_report(results: Path, out: Path | None = None, *, drawn: bool = False) -> Path:
    """Write the page of ``results`` (results.h5 or its folder) to ``out`` (default:
    report.html beside it), whole or not at all; the path written. ``drawn``: the run that
    wrote results.h5 has just drawn its pictures into the folder (each analysis lists them):
    those are taken instead of drawing them again."""
    path = results / "results.h5" if results.is_dir() else results
    out = out or path.parent / REPORT
    text = page(path, drawn=drawn)
    with written(out) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out


def page(path: Path, *, drawn: bool = False) -> str:
    """The HTML of the page of results file ``path`` (``drawn``: see write_report)."""
    if not path.is_file():
        leftover = path.with_name(path.name + ".tmp")
        why = (f"no {path.name} in {path.parent}: only {leftover.name}, left by a run that "
               "was killed before it finished or is still running" if leftover.is_file()
               else f"no {path.name} in {path.parent}: the run did not write one")
        return _missing(path, why)
    try:
        f = open_results(path)
    except ResultsError as err:
        return _missing(path, str(err))
    with f, tempfile.TemporaryDirectory() as scratch:
        return _document(f, Path(scratch), path.parent if drawn else None)


def case_table(f: h5py.File) -> dict:
    """The case a results file was run from (its TOML tables), {} if it keeps none."""
    return json.loads(attr_text(f["case"].attrs["json"])) if "case" in f else {}


def _missing(path: Path, why: str) -> str:
    """The page of a results file that cannot be read."""
    body = (f"<h1>{escape(str(path.parent))}</h1><p class='status status-missing'>no "
            f"results</p><p class='missing'>{escape(why)}</p><p>Run the case again "
            "(<code>microslip run CASE --out FOLDER</code>) to get its results and this "
            "page.</p>")
    return html_page("microslip: no results", body)


def html_page(title: str, body: str, script: str = "") -> str:
    return (f"<!doctype html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{escape(title)}</title><style>{STYLE}</style></head>\n<body>\n{body}\n"
            + (f"<script>\n{script}\n</script>\n" if script else "") + "</body></html>\n")


def _document(f: h5py.File, scratch: Path, folder: Path | None) -> str:
    """The whole page of an open results file (pictures drawn into ``scratch``, or taken
    from ``folder`` where its run drew them)."""
    a = f.attrs
    case = case_table(f)
    title = attr_text(a["title"])
    status, message = attr_text(a["status"]), attr_text(a["message"])
    # in the case's order (the file's groups are sorted by name)
    listed = [a.get("name") for a in case.get("analysis", [])]
    names = sorted((n for n in f if n not in NOT_ANALYSES),
                   key=lambda n: listed.index(n) if n in listed else len(listed))
    parts = [f"<header><h1>{escape(title)}</h1>",
             f"<p><span class='status status-{escape(status)}' id='run-status'>"
             f"{escape(status)}</span> {escape(message)}</p>"]
    if case.get("description"):
        parts.append(f"<p class='about'>{escape(case['description'].strip())}</p>")
    absent = [n for n in listed if n and n not in f]
    if absent:  # a run stopped before them (interrupted, or failed earlier)
        parts.append("<p class='missing'>Not in the results (the run stopped before "
                     f"them): {escape(', '.join(absent))}</p>")
    if names:
        parts.append("<nav><b>Analyses:</b> " + " &middot; ".join(
            f"<a href='#a-{escape(n)}'>{escape(n)}</a>" for n in names) + "</nav>")
    parts.append("</header>")
    if "geometry" in f:
        parts.append(_geometry(f["geometry"], scratch / "geometry", folder))
    if "reduction" in f:
        parts.append(_reduction(f["reduction"]))
    for name in names:
        parts.append(_analysis(f[name], name, scratch / name, folder))
    versions = json.loads(attr_text(a["versions"]))
    parts.append(f"<footer>From {escape(attr_text(a['source']))}, {escape(attr_text(a['created']))}"
                 f"; case {escape(attr_text(a['case_hash'])[:12])}; "
                 + ", ".join(f"{escape(k)} {escape(str(versions[k]))}" for k in sorted(versions))
                 + ". Drawn from results.h5 alone (<code>microslip report</code>).</footer>")
    script = files("microslip.report").joinpath("plot.js").read_text(encoding="utf-8")
    return html_page(title, "\n".join(parts), script)


def _geometry(g: h5py.Group, scratch: Path, folder: Path | None) -> str:
    """The mesh previews (``folder``'s where its run drew them all, else drawn)."""
    from microslip.draw.previews import MeshView, geometry_previews, preview_names

    figures, fault = None, ""
    if folder is not None:
        paths = [folder / n for n in preview_names(MeshView.from_results(g.file))]
        figures = paths if all(p.is_file() for p in paths) else None
    if figures is None:
        scratch.mkdir(parents=True, exist_ok=True)
        figures, fault = _drawn(lambda: geometry_previews(g, "geometry", scratch, Options()))
    return ("<section id='a-geometry'><h2>The model <small>mesh</small></h2>"
            + fault + "".join(_figure(p, caption("geometry", "geometry", p.name))
                              for p in figures) + "</section>")


def _reduction(g: h5py.Group) -> str:
    """The reduced models and the contact stiffness."""
    try:
        body = "".join(_table(t) for t in reduction_tables(g))
    except (KeyError, ValueError) as err:  # a partial or older group
        body = f"<p class='missing'>reduction not shown: {escape(str(err))}</p>"
    return ("<section id='a-reduction'><h2>The reduced models <small>reduction</small></h2>"
            "<p>The bodies' finite-element models reduced per nodal diameter (cyclic "
            "symmetry, Craig-Bampton): what the harmonic balance solves.</p>"
            + body + "</section>")


def _analysis(g: h5py.Group, name: str, scratch: Path, folder: Path | None) -> str:
    """One analysis: what it computes, its status, warnings, tables, plots, pictures (from
    ``folder`` where the run drew them all, else drawn into ``scratch``)."""
    from microslip.case.kinds import kinds_or_shipped

    kind = attr_text(g.attrs.get("type", ""))
    status = attr_text(g.attrs.get("status", "")) or "partial"
    out = [f"<section id='a-{escape(name)}'><h2>{escape(name)} <small>{escape(kind)}"
           f"</small></h2>", f"<p>{escape(ABOUT.get(kind, ''))}</p>",
           *([f"<p class='figure'><b>Reproduces</b> Firrone &amp; Zucca "
              f"{escape(attr_text(g.attrs['figure']))}</p>"]
             if attr_text(g.attrs.get("figure", "")) else []),
           f"<p><span class='status status-{escape(status)}'>{escape(status)}</span> "
           f"{escape(attr_text(g.attrs.get('message', '')))}"
           + (f" ({float(g.attrs['elapsed_s']):.1f} s)" if "elapsed_s" in g.attrs else "")
           + "</p>"]
    out += [f"<p class='warn'>{escape(w)}</p>" for w in _warnings(g)]
    try:
        out += [_table(t) for t in tables(kind, g)]
    except (KeyError, ValueError, IndexError) as err:  # a partial or older group
        out.append(f"<p class='missing'>numbers not shown: {escape(str(err))}</p>")
    if kind == "frf":
        out += [_interactive(p) for p in _plots(g, name)]
    known = kinds_or_shipped(None)
    figures = _run_pictures(g, folder)
    if figures is None and kind in known and known[kind].draw is not None:
        scratch.mkdir(parents=True, exist_ok=True)
        figures, fault = _drawn(lambda: known[kind].draw(g, name, scratch, Options()))
        out.append(fault)
    par = getattr(_spec(g), "parameter", "frequency")
    out += [_figure(p, caption(kind, name, p.name, par)) for p in figures or ()]
    out.append("</section>")
    return "\n".join(out)


def _run_pictures(g: h5py.Group, folder: Path | None) -> list[Path] | None:
    """The pictures the run drew of this analysis, where they are all in ``folder``."""
    if folder is None or "pictures" not in g.attrs:
        return None
    paths = [folder / n for n in json.loads(attr_text(g.attrs["pictures"]))]
    return paths if all(p.is_file() for p in paths) else None


def _spec(g: h5py.Group):
    try:
        return analysis_spec(g)
    except (KeyError, ValueError, TypeError):
        return None


def _plots(g: h5py.Group, name: str) -> list[dict]:
    try:
        return frf_plots(g, name)
    except (KeyError, ValueError, IndexError):
        return []


def _drawn(draw) -> tuple[list[Path], str]:
    """The pictures ``draw()`` writes, and a line where it could not draw them all."""
    try:
        return list(draw()), ""
    except Exception as err:  # a broken group must not take the page with it: say so
        return [], (f"<p class='missing'>pictures not drawn: {escape(type(err).__name__)}: "
                    f"{escape(str(err))}</p>")


def _warnings(g: h5py.Group) -> list[str]:
    """The warning lines the analysis' curves gave."""
    out = []
    for _, c in curves(g):
        out += json.loads(attr_text(c.attrs["warnings"])) if "warnings" in c.attrs else []
    return out


def _table(t: Table) -> str:
    head = "".join(f"<th>{escape(h)}</th>" for h in t.head)
    rows = "".join("<tr>" + "".join(f"<td>{escape(v)}</td>" for v in r) + "</tr>"
                   for r in t.rows)
    return f"<table><caption>{escape(t.title)}</caption><tr>{head}</tr>{rows}</table>"


def _interactive(plot: dict) -> str:
    """A plot's container: its data as JSON for plot.js (``</`` escaped inside the
    script element)."""
    data = json.dumps(plot, separators=(",", ":")).replace("</", "<\\/")
    return (f"<div class='ms-plot'><script type='application/json'>{data}</script>"
            "<noscript>(the interactive plot needs JavaScript: the pictures below show "
            "the same curves)</noscript></div>")


def _figure(path: Path, text: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f"<figure id='fig-{escape(path.stem)}'><img src='data:image/png;base64,{data}' "
            f"alt='{escape(text)}'>"
            f"<figcaption><b>{escape(path.name)}</b>: {escape(text)}</figcaption></figure>")
