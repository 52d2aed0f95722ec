"""The index page over several results folders: the teaching set as a course. Each run's
page linked in the order given, with its status and one paragraph of what a student should
see in it (the case's ``description``, else its title)."""

from __future__ import annotations

import os
from html import escape
from pathlib import Path

from microslip.draw.files import written
from microslip.results.writer import ResultsError, attr_text, open_results

from .page import REPORT, case_table, html_page


def write_index(folders: list[Path], out: Path, title: str = "microslip: the course") -> Path:
    """``out`` (an .html file, or a folder for its index.html) linking the page of each of
    ``folders`` (results folders, written by ``run``), in their order; the path written."""
    out = out / "index.html" if out.suffix != ".html" else out
    out.parent.mkdir(parents=True, exist_ok=True)
    items = [_item(k + 1, Path(d), out.parent) for k, d in enumerate(folders)]
    body = (f"<h1>{escape(title)}</h1><p>Each case's page opens offline; read them in this "
            "order. Every page says what its case computes, shows its pictures with what "
            "they draw, and its key numbers.</p><ol class='course'>" + "".join(items)
            + "</ol>")
    with written(out) as tmp:
        tmp.write_text(html_page(title, body), encoding="utf-8")
    return out


def _item(number: int, folder: Path, base: Path) -> str:
    """One case of the course: its title linked to its page, status and paragraph."""
    page = folder / REPORT
    link = escape(Path(os.path.relpath(page, base)).as_posix())
    try:
        with open_results(folder / "results.h5") as f:
            title, status = attr_text(f.attrs["title"]), attr_text(f.attrs["status"])
            case = case_table(f)
    except (ResultsError, OSError, KeyError) as err:
        return (f"<li><b>{escape(folder.name)}</b> <span class='status status-missing'>no "
                f"results</span><p class='missing'>{escape(str(err))}</p></li>")
    about = case.get("description", "").strip() or title
    there = "" if page.is_file() else \
        " <span class='missing'>(no page yet: microslip report " + escape(str(folder)) + ")</span>"
    return (f"<li id='case-{number}'><a href='{link}'><b>{escape(title)}</b></a> "
            f"<span class='status status-{escape(status)}'>{escape(status)}</span>{there}"
            f"<p>{escape(about)}</p></li>")
