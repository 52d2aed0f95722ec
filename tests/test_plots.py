"""The pictures a reader gets: units on the axes, optima marked, log axes for ranges
spanning decades, legends that say what a curve is, sparse points shown, and mesh
previews rendered off screen without a display and without VTK noise."""

import copy
import os
import subprocess
import sys
from pathlib import Path

import h5py
import matplotlib.image as mpimg
import numpy as np
import pytest

from microslip import case as cases
from microslip.app.run import run_case
from microslip.draw import plots

CASES = Path(__file__).parents[1] / "cases"


def run_drawn(case: cases.Case, out: Path, monkeypatch) -> dict:
    """Run a case and keep the figures it draws, by picture file name."""
    figures = {}
    for kind in ("curves", "loops"):
        draw = getattr(plots, kind)

        def keep(path, *args, _draw=draw, **kw):
            figures[Path(path).name] = _draw(path, *args, **kw)
            return figures[Path(path).name]

        monkeypatch.setattr(plots, kind, keep)
    run_case(case, out, progress=lambda m: None)
    return figures


@pytest.fixture(scope="module")
def sdof(tmp_path_factory):
    """Single DOF on a wall (cases/01_sdof_wall.toml), cut down: an FRF family of two preloads
    and a 9-point optimization curve (peak against the preload)."""
    data = copy.deepcopy(cases.load(CASES / "01_sdof_wall.toml").data)
    frf, opt = data["analysis"][0], data["analysis"][2]
    frf["family"]["values"] = [0.0, 0.05]
    opt["points"] = 9
    data["analysis"] = [frf, opt]
    cases.check(data)
    out = tmp_path_factory.mktemp("sdof")
    with pytest.MonkeyPatch.context() as mp:
        figures = run_drawn(cases.Case(data, "sdof_small"), out, mp)
    with h5py.File(out / "results.h5") as f:
        curve = {k: f["optimization/curve_000"][k][()] for k in ("parameter", "amplitude")}
    return figures, curve


def legend_texts(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_frf_axes_carry_units(sdof):
    ax = sdof[0]["frf_N0_x.png"].axes[0]
    assert ax.get_ylabel() == "max |x(t)| [m]"
    assert ax.get_xlabel().endswith("[rad/s]")


def test_family_legend_reads_value_and_unit(sdof):
    assert legend_texts(sdof[0]["frf_N0_x.png"].axes[0]) == ["N0 = 0 N", "N0 = 0.05 N"]


def test_optimization_curve_marks_and_labels_its_minimum(sdof):
    figures, curve = sdof
    ax = figures["optimization.png"].axes[0]
    assert "[m]" in ax.get_ylabel()
    i = int(np.argmin(curve["amplitude"]))
    x, y = curve["parameter"][i], curve["amplitude"][i]
    assert 0 < i < 8  # an optimum inside the range: a real minimum is marked
    stars = [line for line in ax.get_lines() if line.get_marker() == "*"]
    assert len(stars) == 1
    sx, sy = stars[0].get_data()
    assert (sx[0], sy[0]) == pytest.approx((x, y))
    assert stars[0].get_label() == f"min {y:.3g} m at preload = {x:.3g}"
    assert stars[0].get_label() in legend_texts(ax)


def test_sparse_curves_show_their_points(sdof, tmp_path):
    ax = sdof[0]["optimization.png"].axes[0]
    assert ax.get_lines()[0].get_marker() == "o"  # 9 computed points
    ax = sdof[0]["frf_N0_x.png"].axes[0]
    assert all(line.get_marker() in ("None", None, "") for line in ax.get_lines())
    x = np.linspace(0.0, 1.0, 10)
    ax = plots.curves(tmp_path / "a.png", "t", "x [m]", [{"x": x, "y": x + 1}], "y [m]").axes[0]
    assert ax.get_lines()[0].get_marker() == "o"


@pytest.mark.parametrize("x, log", [
    (np.geomspace(0.005, 0.3, 30), True),   # preload over 1.8 decades
    (np.geomspace(0.1, 2.0, 30), False),    # 1.3 decades: linear
    (np.linspace(0.0, 1.5, 30), False),     # a zero: no log axis
])
def test_log_axis_only_when_the_range_spans_decades(tmp_path, x, log):
    y = 1.0 + x  # under a decade: y stays linear
    ax = plots.curves(tmp_path / "c.png", "t", "preload [-]", [{"x": x, "y": y}],
                      "y [m]").axes[0]
    assert ax.get_xscale() == ("log" if log else "linear")
    assert ax.get_yscale() == "linear"


def test_log_axis_for_responses_spanning_decades(tmp_path):
    w = np.linspace(0.5, 2.5, 100)
    series = [{"x": w, "y": f / np.abs(1 - w**2 + 0.02j * w), "label": f"F = {f:g} N"}
              for f in (0.01, 1.0)]
    ax = plots.curves(tmp_path / "f.png", "t", "w [rad/s]", series, "max |x(t)| [m]").axes[0]
    assert ax.get_yscale() == "log" and ax.get_xscale() == "linear"


def test_a_curve_with_no_value_is_left_out_of_the_legend(tmp_path):
    x = np.linspace(0.0, 1.0, 5)
    series = [{"x": x, "y": x, "label": "N0"}, {"x": x, "y": np.full(5, np.nan), "label": "T0"}]
    ax = plots.curves(tmp_path / "s.png", "t", "w", series, "force [N]").axes[0]
    assert legend_texts(ax) == ["N0"]


def test_number_rounds_and_shows_roundoff_as_zero():
    assert plots.number(-4.39e-17, scale=8.0) == "0"
    assert plots.number(1.76e-16, scale=8.0) == "0"
    assert plots.number(2.3712345) == "2.37"
    assert plots.number(1e-5, scale=1.0) == "1e-05"  # small but not round-off


def test_loop_legends_say_amplitude_and_energy(tmp_path, monkeypatch):
    case = cases.load(CASES / "02_hysteresis_loops.toml")
    figures = run_drawn(case, tmp_path, monkeypatch)
    labels = legend_texts(figures["fig3_law_A.png"].axes[0])
    assert labels[0] == "u amplitude 0.5 m: stick, W = 0 J"
    assert labels[-1] == "u amplitude 3 m: stick-slip, W = 8 J"
    assert not any("e-" in t for t in labels)  # no round-off energies like -4e-17 J
    labels = legend_texts(figures["fig7_law_B.png"].axes[0])
    assert labels[1].startswith("v amplitude 0.3 m: ")  # the amplitudes scale v only
    labels = legend_texts(figures["fig11_law_D.png"].axes[0])
    assert labels[-1] == "dotted: Coulomb limit mu max N"


PREVIEW = """
import sys
from microslip.draw.previews import render_previews
from microslip.geometry.simple import annular_sector
for p in render_previews(annular_sector(size=0.02), sys.argv[1]):
    print(p)
"""


def test_previews_without_a_display_are_quiet_and_drawn(tmp_path):
    """No DISPLAY: VTK renders off screen by itself, with nothing on stderr (it used to
    print an X server warning in raw colour codes); the pictures show the model."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    out = subprocess.run([sys.executable, "-c", PREVIEW, str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "WARN" not in out.stderr and "\x1b[" not in out.stderr, out.stderr
    assert "X server" not in out.stderr
    paths = out.stdout.split()
    assert [Path(p).name for p in paths] == ["annular_sector_sector.png",
                                             "annular_sector_full_disk.png"]
    for p in paths:
        img = mpimg.imread(p)[..., :3]
        model = img[img.shape[0] // 10:]  # below the title strip
        assert np.mean(np.any(model < 0.95, axis=-1)) > 0.03, p


def test_a_branch_line_puts_the_bifurcations_between_their_points(tmp_path):
    """The drawn line of a curve: each located bifurcation inserted after its point (its
    stability -1: where the solid and the dashed parts meet), the turning points and the
    jumps moved to the computed points' new places."""

    from microslip.draw.pictures import branch_line

    with h5py.File(tmp_path / "c.h5", "w") as f:
        c = f.create_group("curve_000")
        c["parameter"] = np.array([0.0, 1.0, 2.0, 1.5, 2.5, 3.0])
        c["response"] = np.arange(6.0)[:, None]
        c["stable"] = np.array([True, True, False, False, True, True])
        c["turning_points"] = np.array([2])
        c["jumps"] = np.array([[4, 5]])
        b = c.create_group("bifurcations")
        b["index"] = np.array([1, 3])
        b["parameter"] = np.array([1.9, 2.2])
        b["response"] = np.array([[1.5], [3.5]])
        b["kind"] = np.array([b"fold", b"fold"])
        line = branch_line(c)
    np.testing.assert_array_equal(line["x"], [0.0, 1.0, 1.9, 2.0, 1.5, 2.2, 2.5, 3.0])
    np.testing.assert_array_equal(line["stable"], [1, 1, -1, 0, 0, -1, 1, 1])
    assert line["turning_points"].tolist() == [3]  # point 2 is now the fourth
    assert line["jumps"].tolist() == [[6, 7]]
    assert [k for k, _, _ in line["bifurcations"]] == ["fold", "fold"]


def test_the_amplification_axis_spans_the_patterns_and_names_a_bound_above(tmp_path):
    """Whitehead's bound (~4 at 48 blades) far above friction-damped patterns (~1.2): the
    axis spans the patterns and the bound is named, not drawn; a level of NaN patterns
    (none completed) still draws."""
    x = np.array([0.0, 1.0, 5.0])
    series = [{"x": x, "y": np.array([1.0, 1.12, 1.2]), "label": "median"},
              {"x": x, "y": np.full(3, np.nan), "label": "largest"}]
    levels = [{"y": 3.96, "label": "Whitehead"}, {"y": 1.0, "label": "tuned"}]
    fig = plots.amplification(tmp_path / "a.png", "t", series, levels)
    ax = fig.axes[0]
    low, high = ax.get_ylim()
    assert low < 1.0 and 1.2 < high < 1.5  # 15 % of the data's span above its top
    assert ax.get_title() == "t\nWhitehead = 3.96: above the axis" and not ax.texts
    assert "tuned" in legend_texts(ax) and "Whitehead" not in legend_texts(ax)
    # the note is the title's, outside the axes: the legend (inside them) cannot cover it
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    title = ax.title.get_window_extent(renderer)
    assert not title.overlaps(ax.get_legend().get_window_extent(renderer))
    assert title.y0 >= ax.get_window_extent(renderer).y1 - 1.0
    nan_only = plots.amplification(tmp_path / "b.png", "t", series[1:], levels)
    assert nan_only.axes[0].get_ylim()[1] > 1.0


def test_a_familys_long_amplification_legend_goes_below_the_axes(tmp_path):
    """Three members' medians and largest, with and without the dampers (12 entries and
    the tuned line): inside the axes the legend covered the curves and ran off the
    picture's left edge; below them it overlaps neither the axes nor the picture's edges."""
    x = np.array([0.0, 1.0])
    series = [{"x": x, "y": np.array([1.0, 1.1 + 0.01 * k]), "label": f"member {k}"}
              for k in range(12)]
    fig = plots.amplification(tmp_path / "a.png", "t", series, [{"y": 1.0, "label": "tuned"}])
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legend = fig.axes[0].get_legend().get_window_extent(renderer)
    assert len(legend_texts(fig.axes[0])) == 13
    assert legend.y1 <= fig.axes[0].get_window_extent(renderer).y0 and not (
        legend.overlaps(fig.axes[0].get_window_extent(renderer)))
    assert legend.x0 >= 0 and legend.y0 >= 0
    assert legend.x1 <= fig.bbox.width


def test_the_exceedance_curve_steps_down_by_one_nth_at_each_value(tmp_path):
    """P(A > a) of three values: 1 below the smallest, then 2/3, 1/3 and 0 from each value
    on (post steps); a curve with no value is left out; the limit is a vertical line."""
    panels = [{"title": "p", "curves": [{"values": [1.2, 1.0, 1.4], "label": "s", "color": "C0"},
                                        {"values": [], "color": "C1", "ls": "--"}]}]
    fig = plots.exceedance(tmp_path / "e.png", "t", panels, limit=1.3)
    ax = fig.axes[0]
    step, limit = ax.lines
    np.testing.assert_allclose(step.get_xdata(), [1.0, 1.0, 1.2, 1.4])
    np.testing.assert_allclose(step.get_ydata(), [1.0, 2 / 3, 1 / 3, 0.0])
    assert step.get_drawstyle() == "steps-post"
    np.testing.assert_allclose(limit.get_xdata(), [1.3, 1.3])
    assert "limit 1.3" in legend_texts(ax)
