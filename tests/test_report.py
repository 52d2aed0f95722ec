"""The results page (pipeline/report): what it holds against results.h5, what it says of a
broken folder, the command and the index, and the page in a real browser (headless
Chromium: no console errors, every picture loaded, a point's numbers when pointed at, the
legend hiding a curve; screenshots at a desktop and a phone width kept for a person)."""

import base64
import copy
import html
import json
import re
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from browser import Browser, missing
from case_helpers import TWO_DOF

from microslip import case as cases
from microslip.app.run import run_case
from microslip.cli import main
from microslip.draw.pictures import render
from microslip.report import write_report
from microslip.report.numbers import length, length_unit

#: where the browser test keeps its screenshots for a person to look at
SHOTS = Path(tempfile.gettempdir()) / "microslip-report-screenshots"

CASE = copy.deepcopy(TWO_DOF) | {
    "title": "two masses, a contact with a variable normal load",
    "description": "The page's test case: an FRF through the resonance and its nonlinear mode.",
    "analysis": [
        {"name": "curve", "type": "frf", "figure": "Fig. 5", "start": 0.8, "stop": 1.2,
         "outputs": ["x"],
         "family": {"key": "contacts.0.n0", "values": [0.3, 0.5]}},
        {"name": "mode", "type": "nonlinear_modes", "output": "x", "amplitude": [0.01, 1.0],
         "excitations": [1.0]},
    ]}
CASE["model"]["damping"] = [0.05, 0.05]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    path = run_case(cases.Case(copy.deepcopy(CASE), "page.toml"), out, progress=lambda m: None)
    return path, write_report(out)


def _text(page: Path) -> str:
    return html.unescape(re.sub(r"<[^>]+>", " ", page.read_text()))


def test_the_page_holds_the_runs_status_numbers_and_pictures(run, tmp_path):
    path, page = run
    text, raw = _text(page), page.read_text()
    with h5py.File(path) as f:
        assert f.attrs["status"] in text and f.attrs["title"] in text
        assert "The page's test case" in text  # the case's description
        assert re.search(r"Reproduces\s+Firrone & Zucca Fig. 5", text)  # its figure
        for key in ("curve_000", "curve_001"):  # every peak as results.h5 has it
            resp = f["curve"][key]["response"][:, 0]
            unit = length_unit([f["curve"][k]["response"][()].max() for k in ("curve_000",
                                                                                "curve_001")])
            assert f"{length(resp.max(), unit)}" in text
        mode = f["mode/curve_000"]
        assert f"{mode['omega'][0]:.6g}" in text  # the linear limit of the mode
    # every picture the results draw, inlined; nothing fetched from elsewhere
    drawn = render(path, tmp_path)
    assert raw.count("src='data:image/png;base64,") == len(drawn)
    assert not re.search(r"""(src|href)=['"](https?:|//|file:)""", raw)
    assert "<link" not in raw
    # the interactive FRF's data are the curves' points
    data = [json.loads(d) for d in re.findall(
        r"<script type='application/json'>(.*?)</script>", raw, re.S)]
    assert len(data) == 1 and len(data[0]["series"]) >= 2
    with h5py.File(path) as f:
        c = f["curve/curve_000"]
        scale = {"m": 1.0, "mm": 1e3, "um": 1e6}[data[0]["unit"]]
        np.testing.assert_allclose(data[0]["series"][0]["y"], scale * c["response"][:, 0],
                                   rtol=1e-6)  # 7 significant digits kept
        assert data[0]["series"][0]["stable"] == [int(s) for s in c["stable"][()]]
        # each point's hysteresis loop, to the page's 1 % of its span (its own span: the
        # force here rides on a static part)
        cd = c["contacts/c"]
        lp, L = data[0]["series"][0]["loops"][0], data[0]["levels"]
        step = -(-cd["loop_u"].shape[-1] // len(lp["u"][0]))
        for i in range(len(lp["T"])):
            want = cd["loop_T"][i, 0, ::step]
            got = lp["T0"][i] + (np.array(lp["T"][i]) + L) * (lp["T1"][i] - lp["T0"][i]) / (2 * L)
            np.testing.assert_allclose(got, want, atol=0.006 * np.ptp(want) + 1e-12)


def test_the_stored_hysteresis_loops_enclose_the_energy_dissipated(run):
    """Each point's stored loop (the contact point dissipating most, at the balance's 64
    samples) encloses the dissipation computed from the harmonic forces: an independent
    check of its point, its sign and its alignment in time."""
    path, _ = run
    with h5py.File(path) as f:
        cd = f["curve/curve_000/contacts/c"]
        u, T = cd["loop_u"][:, 0, :].astype(float), cd["loop_T"][:, 0, :].astype(float)
        work = np.sum(0.5 * (T + np.roll(T, -1, 1)) * (np.roll(u, -1, 1) - u), axis=1)
        d = cd["dissipation"][()]
        assert u.shape[1] == f["curve/curve_000"].attrs["samples"] == 64  # every sample
    slipping = d > 1e-3 * d.max()
    assert slipping.sum() > 10
    # the polygon through the samples cuts the loop's stick-slip and lift-off corners, each
    # by up to a sample (1/64 of the period): 1.7 % measured, hence 3 %
    np.testing.assert_allclose(work[slipping], d[slipping], rtol=0.03)


def test_a_missing_or_broken_results_folder_gives_a_page_that_says_so(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "the run did not write one" in _text(write_report(empty))
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "results.h5").write_bytes(b"not an HDF5 file")
    assert "cannot open as HDF5" in _text(write_report(broken))
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / "results.h5.tmp").write_bytes(b"")
    assert "killed before it finished" in _text(write_report(killed))


def test_the_page_of_a_partial_run_names_the_analyses_it_lacks(run, tmp_path):
    import shutil

    path, _ = run
    shutil.copy(path, tmp_path / "results.h5")
    with h5py.File(tmp_path / "results.h5", "a") as f:  # as a run stopped before "mode"
        del f["mode"]
        f.attrs["status"] = "partial"
    text = _text(write_report(tmp_path))
    assert "Not in the results (the run stopped before them): mode" in text
    assert "partial" in text


def test_report_writes_pages_and_an_index_in_the_order_given(run, tmp_path, capsys):
    path, _ = run
    empty = tmp_path / "not_run"
    empty.mkdir()
    assert main(["report", str(path.parent), str(empty), "--index", str(tmp_path / "course")]) == 0
    index = tmp_path / "course" / "index.html"
    raw = index.read_text()
    # the run's page linked relative to the index, then the folder without results
    link = re.search(r"href='([^']+)'", raw).group(1)
    assert (index.parent / link).resolve() == (path.parent / "report.html").resolve()
    assert raw.index("two masses") < raw.index("not_run")
    assert "no results" in _text(index)
    assert main(["report", str(tmp_path / "nowhere")]) == 2
    assert "no such file or folder" in capsys.readouterr().err


def test_a_run_writes_its_page_unless_told_not_to(tmp_path):
    """(The README's walk-through runs a shipped case and opens its page: test_readme.)"""
    case = tmp_path / "c.toml"
    case.write_text(LINEAR)
    assert main(["run", str(case), "--out", str(tmp_path / "a"), "--workers", "0"]) == 0
    assert "complete" in _text(tmp_path / "a" / "report.html")
    # the run's page takes the pictures the run drew (not drawn twice): the same bytes
    raw = (tmp_path / "a" / "report.html").read_text()
    pictures = sorted((tmp_path / "a").glob("*.png"))
    assert pictures and all(base64.b64encode(p.read_bytes()).decode() in raw
                            for p in pictures)
    assert main(["run", str(case), "--out", str(tmp_path / "b"), "--workers", "0",
                 "--no-report"]) == 0
    assert not (tmp_path / "b" / "report.html").exists()


def test_ctrl_c_while_the_page_is_written_keeps_the_results_and_leaves_no_page(
        tmp_path, monkeypatch, capsys):
    from microslip import report
    from microslip.cli.shared import INTERRUPTED

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "write_report", interrupted)
    case = tmp_path / "c.toml"
    case.write_text(LINEAR)
    assert main(["run", str(case), "--out", str(tmp_path / "a"), "--workers", "0"]) == \
        INTERRUPTED
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "interrupted while writing the page" in err[0]
    assert "results are complete" in err[0] and "microslip report" in err[0]
    with h5py.File(tmp_path / "a" / "results.h5") as f:
        assert f.attrs["status"] == "complete"
    assert not list((tmp_path / "a").glob("*.html"))


#: a linear oscillator's FRF (sampled, no continuation): the quickest run there is
LINEAR = """title = "a linear oscillator"
[model]
dofs = ["x"]
mass = [1.0]
stiffness = [1.0]
damping = [0.02]
[[loads]]
dof = "x"
amplitude = 0.1
harmonic = 1
[harmonics]
max = 1
samples = 32
[[analysis]]
name = "a"
type = "frf"
start = 0.5
stop = 1.5
"""


@pytest.mark.skipif(bool(missing()), reason=missing() or "browser present")
def test_the_page_in_a_browser(run, tmp_path):
    """No console error, every picture loaded, the status and peaks on the page as in
    results.h5, the numbers of a point when pointed at, a curve hidden by its legend box;
    screenshots at 1280 and 390 px wide (kept in SHOTS)."""
    path, page = run
    SHOTS.mkdir(exist_ok=True)
    with Browser(tmp_path / "profile") as b:
        b.open(page.as_uri())
        assert b.run("return document.getElementById('run-status').textContent;") == \
            h5py.File(path)["/"].attrs["status"]
        loaded = b.run("return Array.from(document.images).map("
                       "i => i.complete && i.naturalWidth > 0);")
        assert loaded and all(loaded)
        data = json.loads(b.run("return document.querySelector("
                                "\".ms-plot script[type='application/json']\").textContent;"))
        # point at the first curve's peak (where the curves part): its numbers appear
        s = data["series"][0]
        i = int(np.nanargmax(np.array(s["y"], dtype=float)))
        circles = b.run("return Array.from(document.querySelectorAll("
                        "\".ms-pt[data-series='0']\")).map(c => +c.dataset.index);")
        b.point_at(".ms-pt[data-series='0']", circles.index(i))
        time.sleep(0.2)
        tip = b.run("return document.querySelector('.ms-tip').innerText;")
        # (near the peak the points crowd: the pointer may land on a neighbour; the numbers
        # shown must be those of the point the tip names)
        j = int(re.search(r"point (\d+) of", tip).group(1)) - 1
        assert abs(j - i) <= 3 and s["label"] in tip
        assert f"{s['x'][j]:.7g}" in tip and f"{s['y'][j]:.5g}" in tip
        assert "response" in tip and "slipping" in tip
        # and the contact's hysteresis loop there, its force range as stored
        lp = s["loops"][0]
        assert b.run("return document.querySelectorAll('.ms-tip svg.ms-loop').length;") == 1
        for end in (lp["T0"][j], lp["T1"][j]):  # its force range, as stored
            assert f"{float(f'{end:.3g}'):g}" in tip
        assert b.element_screenshot(".ms-plot", SHOTS / "page_point.png").stat().st_size > 5_000
        # the legend's box hides the first curve's points, and shows them again
        count = "return document.querySelectorAll(\".ms-pt[data-series='0']\").length;"
        shown = b.run(count)
        b.run("document.querySelector('.ms-legend input').click();")
        assert shown > 0 and b.run(count) == 0
        b.run("document.querySelector('.ms-legend input').click();")
        assert b.run(count) == shown
        errors = [e for e in b.console() if e.get("level") == "SEVERE"]
        assert not errors, errors
        assert b.screenshot(SHOTS / "page_desktop.png").stat().st_size > 10_000
        b.size(390, 844)
        assert b.screenshot(SHOTS / "page_phone.png").stat().st_size > 10_000


def _layout_faults(fig) -> list[str]:
    """What a reader would trip on in a matplotlib figure: a labelled curve missing from
    its legend, text boxes (title, axis labels, legend) overlapping one another, or any of
    them (tick labels too) cut by the canvas' edge."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    canvas = fig.bbox
    faults = []
    for ax in fig.axes:
        legend = ax.get_legend()
        named = {t.get_text() for t in legend.get_texts()} if legend else set()
        for line in ax.get_lines():
            label = line.get_label()
            if len(line.get_xdata()) and label and not label.startswith("_") \
                    and label not in named:
                faults.append(f"{ax.get_title()}: curve {label!r} not in the legend")
        boxes = [(what, t.get_window_extent(r)) for what, t in (
            ("title", ax.title), ("x label", ax.xaxis.label), ("y label", ax.yaxis.label))
            if t.get_text()]
        if legend:
            boxes.append(("legend", legend.get_window_extent(r)))
        for i, (a, ba) in enumerate(boxes):
            for b, bb in boxes[i + 1:]:
                if ba.overlaps(bb):
                    faults.append(f"{ax.get_title()}: {a} overlaps {b}")
        ticks = [t.label1.get_window_extent(r) for axis in (ax.xaxis, ax.yaxis)
                 for t in axis.get_major_ticks() if t.label1.get_visible()
                 and t.label1.get_text() and min(axis.get_view_interval())
                 <= t.get_loc() <= max(axis.get_view_interval())]
        for what, box in boxes + [("a tick label", t) for t in ticks]:
            if box.x0 < canvas.x0 - 1 or box.x1 > canvas.x1 + 1 or box.y0 < canvas.y0 - 1 \
                    or box.y1 > canvas.y1 + 1:
                faults.append(f"{ax.get_title()}: {what} cut by the canvas")
    return faults


def test_every_line_picture_names_its_curves_and_nothing_overlaps(run, tmp_path,
                                                                   monkeypatch):
    """Every matplotlib picture the run's results draw (FRFs with their limits, static
    forces, the mode's pictures), checked as drawn: each labelled curve in its legend, no
    text box on another, nothing cut; the lengths in the unit a person reads."""
    from microslip.draw import plots

    drawn = []
    save = plots._save
    monkeypatch.setattr(plots, "_save", lambda fig, path: drawn.append(save(fig, path))
                        or drawn[-1])
    path, _ = run
    render(path, tmp_path)
    assert len(drawn) >= 5
    faults = [f for fig in drawn for f in _layout_faults(fig)]
    assert not faults, faults
    # an axis in m holds lengths of at least 0.5 m (smaller ones read in mm or um)
    for ax in (ax for fig in drawn for ax in fig.axes):
        for label, values in ((ax.get_ylabel(), [ln.get_ydata() for ln in ax.get_lines()]),
                              (ax.get_xlabel(), [ln.get_xdata() for ln in ax.get_lines()])):
            if " [m]" in label:
                top = max(np.nanmax(np.abs(np.asarray(v, float))) for v in values if len(v))
                assert top >= 0.5, (label, top)


@pytest.mark.skipif(bool(missing()), reason=missing() or "browser present")
def test_the_page_without_javascript_keeps_its_pictures_and_tables(run, tmp_path):
    _, page = run
    with Browser(tmp_path / "profile", scripts=False) as b:
        b.open(page.as_uri())
        # WebDriver's own scripts still run; the page's do not: no plot was drawn
        assert b.run("return document.querySelectorAll('.ms-svg').length;") == 0
        loaded = b.run("return Array.from(document.images).map("
                       "i => i.complete && i.naturalWidth > 0);")
        assert loaded and all(loaded)
        assert b.run("return document.querySelectorAll('table').length;") >= 3
        assert "needs JavaScript" in b.run("return document.body.innerText;")


def test_a_whole_disks_tooltip_shows_its_own_blades_loops(tmp_path):
    """A whole disk's FRF has an output per blade ("tip#s") and every sector's patches
    ("damper_left#s"): the plot of blade s carries the loops of sector s's contacts only
    (all of them would be 2N loops a tooltip, N^2 on the page); a cyclic sector's output
    keeps every contact's, and so does every output a contact of no sector."""
    from microslip.report.interactive import _loops

    with h5py.File(tmp_path / "r.h5", "w") as f:
        c = f.create_group("curve")
        for name in ("damper_left#0", "damper_left#1", "damper_right#1", "damper_left#10",
                     "slot"):
            cd = c.create_group(f"contacts/{name}")
            cd["loop_u"] = np.linspace(0, 1e-6, 2 * 64).reshape(2, 1, 64)
            cd["loop_T"] = np.linspace(-1.0, 1.0, 2 * 64).reshape(2, 1, 64)
        assert [lp["contact"] for lp in _loops(c, 1)] == [
            "damper_left#1", "damper_right#1", "slot"]  # (a contact of no sector: kept)
        assert [lp["contact"] for lp in _loops(c, 10)] == ["damper_left#10", "slot"]
        assert len(_loops(c)) == 5
