"""PNG pictures of a run (matplotlib, headless): FRFs and families of FRFs,
parameter curves (optimization and performance plots), hysteresis loops and 2D
force trajectories, time integration against harmonic balance.

Every function saves its PNG and returns the matplotlib Figure (tests read its axes)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from microslip.draw.files import written

if TYPE_CHECKING:  # matplotlib loads when a picture is drawn (as pyvista does in maps)
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

LABELS = {
    "frequency": "excitation frequency w [rad/s]",
    "excitation": "excitation: multiple of the nominal load [-]",
    "preload": "preload: multiple of the case's N0 [-]",
    "mass": "mass: multiple of the nominal mass [-]",
}
DECADES = 1.5  # an axis whose positive values span more decades than this is drawn in log
SPARSE = 50  # a curve of fewer computed points shows them as markers


def _figure(size: tuple[float, float]) -> Figure:
    """A figure on its own Agg canvas: files only, no display needed, no pyplot state
    (so no global backend switch and nothing to close)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: Path) -> Figure:
    fig.tight_layout()
    with written(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return fig


def decades(arrays: Sequence) -> float:
    """Decades spanned by the finite values; 0 unless there are two and all are positive."""
    v = np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in arrays] or [[]])
    v = v[np.isfinite(v)]
    return float(np.log10(v.max() / v.min())) if v.size > 1 and v.min() > 0 else 0.0


def spans_decades(arrays: Sequence) -> bool:
    """True when the finite values are all positive and span more than DECADES decades."""
    return decades(arrays) > DECADES


def number(value: float, scale: float = 0.0, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits; "0" when it is round-off next to
    ``scale`` (a dissipation of -4e-17 J beside 8 J is zero)."""
    if value == 0 or abs(value) <= 1e-9 * abs(scale):
        return "0"
    return f"{value:.{digits}g}"


#: Markers of the bifurcations by kind (pictures draw each kind once in the legend).
BIFURCATION_MARKERS = {"fold": "o", "branch point": "s", "period doubling": "D",
                       "Neimark-Sacker": "^"}


def _line(ax: Axes, s: dict) -> Line2D | None:
    """One computed curve: markers on its points when they are sparse, its unstable parts
    dashed (``stable``: per point 1, 0, or -1 at a bifurcation, where both parts meet),
    its bifurcations marked by kind, or else (no stability) its turning points circled;
    jumps at folds (``jumps``: (from, to) point indices) drawn as thin dashed arrows
    between the branches rather than as part of the line; a curve with no finite point is
    left out (and out of the legend)."""
    x, y = np.asarray(s["x"], dtype=float), np.asarray(s["y"], dtype=float)
    finite = np.isfinite(y)
    if not finite.any():
        return None
    jumps = np.asarray(s.get("jumps", np.zeros((0, 2), int)), dtype=int).reshape(-1, 2)
    stable = s.get("stable")
    stable = np.ones(len(x), int) if stable is None else np.asarray(stable, int)
    xs, ys, st = x, y, stable
    if len(jumps):  # a NaN between the two points of a jump breaks the line there
        xs, ys = np.insert(x, jumps[:, 1], np.nan), np.insert(y, jumps[:, 1], np.nan)
        st = np.insert(stable, jumps[:, 1], 1)
    marker = "o" if finite.sum() < SPARSE else None
    # the stable parts solid, between points not unstable; the unstable ones dashed,
    # between points not stable (a bifurcation belongs to both)
    (line,) = ax.plot(xs, np.where(st != 0, ys, np.nan), label=s.get("label"),
                      lw=s.get("lw", 1.4), ls=s.get("ls", "-"), color=s.get("color"),
                      marker=marker, ms=3)
    if np.any(stable == 0):
        # a segment from a stable point to an unstable one (no bifurcation point between,
        # e.g. on a peak curve) is drawn dashed
        unstable = st == 0
        near = unstable | np.append(unstable[1:], False) | np.insert(unstable[:-1], 0, False)
        ax.plot(xs, np.where(near | (st == -1), ys, np.nan), lw=s.get("lw", 1.4),
                ls=(0, (3, 2)),
                color=line.get_color(), marker=marker, ms=3, mfc="none")
    named = {m.get_label() for m in ax.get_lines()}
    for kind, xb, yb in s.get("bifurcations", ()):
        label = f"{kind} (dashed: unstable)"
        ax.plot([xb], [yb], BIFURCATION_MARKERS.get(kind, "x"), mfc="none", ms=7, mew=1.2,
                color=line.get_color(), ls="none", label=None if label in named else label)
        named.add(label)
    tp = s.get("turning_points", [])
    if len(tp) and s.get("stable") is None:
        ax.plot(x[tp], y[tp], "o", mfc="none", color=line.get_color(), ms=7)
    for i, j in jumps:
        if not np.isfinite([x[i], y[i], x[j], y[j]]).all():
            continue
        ax.annotate("", xy=(x[j], y[j]), xytext=(x[i], y[i]),
                    arrowprops={"arrowstyle": "->", "ls": "--", "lw": 0.8,
                                "color": line.get_color(), "shrinkA": 0, "shrinkB": 0})
    return line


def _mark_optimum(ax: Axes, line: Line2D, what: str, unit: str) -> None:
    """A star on the curve's minimum, labelled in the legend (beside its curve) with the
    value and the parameter there: floating labels of a family's optima collide."""
    x, y = (np.asarray(v, dtype=float) for v in line.get_data())
    i = int(np.nanargmin(y))
    ax.plot(x[i], y[i], "*", color=line.get_color(), ms=13, mec="black", mew=0.6, zorder=5,
            ls="none", label=f"min {number(y[i])} {unit} at {what} = {number(x[i])}")


def _scale(ax: Axes, axis: str, log: bool | None, arrays: list) -> None:
    """Log when asked, or (log=None) when the data span decades; linear otherwise."""
    if not (log if log is not None else spans_decades(arrays)):
        return
    getattr(ax, f"set_{axis}scale")("log")
    ax.grid(True, which="minor", axis=axis, alpha=0.12)  # values between the decades
    if 0 < decades(arrays) <= 3:  # few decades: ticks at 1, 2, 5 x 10^n read as plain numbers
        from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

        scale = getattr(ax, f"{axis}axis")
        scale.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        scale.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        scale.set_minor_formatter(NullFormatter())


def length_unit(values) -> tuple[float, str]:
    """(factor, unit) that shows lengths [m] as a person reads them: m from 0.5 m (a
    teaching oscillator's), mm from 0.5 mm, else um (by the largest finite value)."""
    v = np.abs(np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in values]
                              or [[]]))
    v = v[np.isfinite(v)]
    top = float(v.max()) if v.size else 1.0
    return (1.0, "m") if top >= 0.5 else (1e3, "mm") if top >= 5e-4 else (1e6, "um")


def _readable(series: Sequence[dict], markers: Sequence[dict], label: str, axis: str
              ) -> tuple[list[dict], list[dict], str, str | None]:
    """Series, markers and label with the ``axis`` values of a length axis ("... [m]") in
    the unit a person reads them in (:func:`length_unit`), and that unit (None: the axis is
    not a length)."""
    if " [m]" not in label:
        return list(series), list(markers), label, None
    factor, unit = length_unit([d[axis] for d in (*series, *markers)])

    def scaled(d: dict) -> dict:
        out = {**d, axis: np.asarray(d[axis], dtype=float) * factor}
        if axis == "y" and "bifurcations" in d:
            out["bifurcations"] = [(k, xb, yb * factor) for k, xb, yb in d["bifurcations"]]
        return out

    return ([scaled(d) for d in series], [scaled(d) for d in markers],
            label.replace(" [m]", f" [{unit}]"), unit)


def curves(path: Path, title: str, xlabel: str, series: Sequence[dict], ylabel: str,
           *, logx: bool | None = None, logy: bool | None = None,
           markers: Sequence[dict] = (), optimum: tuple[str, str] | None = None) -> Figure:
    """Lines ``{x, y, label}`` (turning points marked where given) and point sets
    ``{x, y, label}`` drawn as markers (time integration; ``text``: a letter beside a
    single marked point).

    ``logx``/``logy`` None: log when the axis' data span decades. ``optimum`` =
    (parameter name, unit of y): mark and label each curve's minimum (but of series with
    ``optimum: False``, e.g. reference levels)."""
    series, markers, xlabel, _ = _readable(series, markers, xlabel, "x")
    series, markers, ylabel, unit = _readable(series, markers, ylabel, "y")
    if optimum and unit:
        optimum = (optimum[0], unit)
    fig = _figure((7, 4.5))
    ax = fig.add_subplot()
    for s in series:
        line = _line(ax, s)
        if optimum and line is not None and s.get("optimum", True):
            _mark_optimum(ax, line, *optimum)
    for m in markers:
        ax.plot(m["x"], m["y"], m.get("style", "ks"), label=m.get("label"), ms=5, mfc="none")
        if m.get("text"):  # a letter beside the marked point (the maps name it)
            ax.annotate(m["text"], (m["x"][0], m["y"][0]), xytext=(4, 4),
                        textcoords="offset points", fontsize=9)
    drawn = list(series) + list(markers)
    _scale(ax, "x", logx, [d["x"] for d in drawn])
    _scale(ax, "y", logy, [d["y"] for d in drawn])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    if any(line.get_label()[:1] not in ("", "_") for line in ax.get_lines()):
        ax.legend(fontsize=8)
    return _save(fig, path)


def mode_errors(path: Path, title: str, rows: Sequence[dict]) -> Figure:
    """Per body and nodal diameter (one line each, ``rows``: label, frequencies_hz,
    relative_error): the reduced model's relative frequency error against the unreduced
    mode's frequency, on log axes (a rigid mode, 0 Hz, is left out)."""
    fig = _figure((7, 5))
    ax = fig.add_subplot()
    for row in rows:
        f, e = np.asarray(row["frequencies_hz"]), np.abs(np.asarray(row["relative_error"]))
        ok = f > 0
        ax.plot(f[ok], np.maximum(e[ok], 1e-16), "o-", ms=4, label=row["label"])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("natural frequency of the unreduced body [Hz]")
    ax.set_ylabel("reduced model's relative frequency error")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, ncol=2)
    return _save(fig, path)


def loops(path: Path, title: str, loops_: Sequence[dict], *, two_d: bool) -> Figure:
    """Hysteresis loops T(u) (1D) or force trajectories (T_x, T_y) with the Coulomb
    circle of the largest normal load (2D, dotted)."""
    fig = _figure((9, 5) if two_d else (6, 5))
    ax = fig.add_subplot()
    for i, lp in enumerate(loops_):
        if two_d:
            T = np.asarray(lp["T"])
            (line,) = ax.plot(np.append(T[0], T[0, 0]), np.append(T[1], T[1, 0]),
                              label=lp["label"])
            lim = np.max(lp["limit"])
            th = np.linspace(0, 2 * np.pi, 200)
            ax.plot(lim * np.cos(th), lim * np.sin(th), ":", color=line.get_color(), lw=0.8,
                    label="dotted: Coulomb limit mu max N" if i == len(loops_) - 1 else None)
        else:
            u, T = np.asarray(lp["u"]), np.asarray(lp["T"])
            ax.plot(np.append(u, u[0]), np.append(T, T[0]), label=lp["label"])
    if two_d:
        ax.set_xlabel("T_x [N]")
        ax.set_ylabel("T_y [N]")
        ax.set_aspect("equal")
    else:
        ax.set_xlabel("tangential relative displacement u [m]")
        ax.set_ylabel("tangential force T [N]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    # the circles fill the square axes: the legend goes beside them
    ax.legend(fontsize=8, **({"loc": "upper left", "bbox_to_anchor": (1.02, 1)} if two_d else {}))
    return _save(fig, path)


def transient(path: Path, title: str, steps: Sequence[dict]) -> Figure:
    """Load steps (Firrone & Zucca Fig. 13): per step, the outputs over time (top) and a
    contact's tangential force with the limits +-mu N (bottom)."""
    fig = _figure((6 * len(steps), 6.5))
    axes = fig.subplots(2, len(steps), squeeze=False)
    for j, st in enumerate(steps):
        ax = axes[0, j]
        for name, q in st["outputs"].items():
            ax.plot(st["t"], q, lw=0.8, label=name)
        ax.set_title(f"{title}: {st['label']}", fontsize=10)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("displacement [m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax = axes[1, j]
        ax.plot(st["t"], st["T"], lw=0.8, label="T")
        ax.plot(st["t"], st["limit"], "k--", lw=0.8, label="slip limits +- mu N")
        ax.plot(st["t"], -st["limit"], "k--", lw=0.8)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"tangential force T, contact {st['contact']} [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return _save(fig, path)


def histogram(path: Path, title: str, values: np.ndarray, xlabel: str,
              levels: Sequence[dict] = ()) -> Figure:
    """The histogram of sampled ``values`` (as a share of the samples), with vertical
    reference ``levels`` ``{x, label, ls}`` (free and stuck peaks, a limit)."""
    fig = _figure((7, 4.5))
    ax = fig.add_subplot()
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    bins = int(np.clip(np.sqrt(v.size), 5, 40))
    ax.hist(v, bins=bins, weights=np.full(v.size, 1.0 / max(v.size, 1)), color="C0",
            alpha=0.75, edgecolor="white", label=f"{v.size} samples")
    for lv in levels:
        ax.axvline(lv["x"], color=lv.get("color", "0.3"), ls=lv.get("ls", "--"), lw=1.2,
                   label=lv["label"])
    ax.set_xlabel(xlabel)
    ax.set_ylabel("share of the samples [-]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return _save(fig, path)


def against_parameters(path: Path, title: str, columns: Sequence[dict], y: np.ndarray,
                       ylabel: str, colour: np.ndarray | None = None,
                       colour_label: str = "") -> Figure:
    """One panel per parameter ``{x, label, note}``: ``y`` against its sampled values (each
    panel titled with its ``note``, e.g. the rank correlation), points coloured by
    ``colour`` when given."""
    k = len(columns)
    fig = _figure((min(1.6 + 3.4 * k, 15.0), 4.2))
    fig.set_layout_engine("constrained")  # places the shared colour bar and the labels
    axes = fig.subplots(1, k, sharey=True, squeeze=False)[0]
    for ax, col in zip(axes, columns):
        dots = ax.scatter(col["x"], y, s=12, c=colour if colour is not None else "C0",
                          cmap="viridis", vmin=0.0, vmax=1.0)
        ax.set_xlabel(col["label"])
        ax.set_title(col.get("note", ""), fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(ylabel)
    if colour is not None:
        fig.colorbar(dots, ax=list(axes), label=colour_label, fraction=0.04, pad=0.02)
    fig.suptitle(title, fontsize=10)
    with written(path) as tmp:
        fig.savefig(tmp, dpi=110)
    return fig


def amplification(path: Path, title: str, series: Sequence[dict], levels: Sequence[dict]
                  ) -> Figure:
    """The worst blade's amplification against the mistuning level [%]: ``series`` ``{x, y,
    label, ls, color, marker, alpha}``, horizontal reference ``levels`` ``{y, label}``
    (Whitehead's bound, the tuned disk)."""
    fig = _figure((7, 4.5))
    ax = fig.add_subplot()
    for s in series:
        ax.plot(s["x"], s["y"], label=s["label"], ls=s.get("ls", "-"), color=s.get("color"),
                marker=s.get("marker"), ms=4, alpha=s.get("alpha", 1.0))
    # the axis spans the patterns, not a bound far above them (Whitehead's at 48 blades is
    # ~4 where friction-damped patterns reach ~1.2): a level off the scale is named instead
    ys = np.concatenate([np.asarray(s["y"], float) for s in series] or [np.ones(1)])
    ys = ys[np.isfinite(ys)]
    low, high = float(np.min(ys, initial=1.0)), float(np.max(ys, initial=1.0))
    top = high + 0.15 * max(high - low, 0.05)
    above = []
    for k, lv in enumerate(levels):
        if lv["y"] > top:
            above.append(f"{lv['label']} = {lv['y']:.3g}")
            continue
        ax.axhline(lv["y"], color="0.4", ls=(":", "-.")[k % 2], lw=1.0, label=lv["label"])
    ax.set_ylim(low - 0.05 * max(high - low, 0.05), top)
    ax.set_xlabel("mistuning: standard deviation of the blades' Young's modulus [%]")
    ax.set_ylabel("amplification: worst blade / tuned [-]")
    # (the note under the title, where the legend, placed inside the axes, cannot cover it)
    note = f"\n{'; '.join(above)}: above the axis" if above else ""
    ax.set_title(title + note, fontsize=10)
    ax.grid(alpha=0.3)
    _legend_fitting(fig, ax)
    return _save(fig, path)


#: legend entries that fit inside an amplification plot's axes without covering its curves
INSIDE_LEGEND = 6


def _legend_fitting(fig: Figure, ax) -> None:
    """The legend inside the axes where it is short; below them, the figure taller by its
    rows, where a family's members make it long (inside, it covered the curves)."""
    entries = len(ax.get_legend_handles_labels()[0])
    if entries <= INSIDE_LEGEND:
        ax.legend(fontsize=7, ncol=2)
        return
    rows = -(-entries // 2)
    width, height = fig.get_size_inches()
    fig.set_size_inches(width, height + 0.17 * rows)
    ax.legend(fontsize=7, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.16))


def exceedance(path: Path, title: str, panels: Sequence[dict], limit: float | None = None
               ) -> Figure:
    """The empirical exceedance probability P(A > a) of the amplification, a panel per
    study (a family member): ``panels`` ``{title, curves: [{values, label, color, ls}]}``,
    each curve a step down by 1 / n at each of its n values; ``limit`` a vertical line."""
    cols = 1 if len(panels) <= 3 else 2 if len(panels) <= 8 else 3
    rows = -(-len(panels) // cols)
    fig = _figure((7 if cols == 1 else 5.5 * cols, 1.0 + 3.0 * rows))
    grid = fig.subplots(rows, cols, squeeze=False, sharex=True)
    axes = grid.ravel()
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    for ax, panel in zip(axes, panels):
        for c in panel["curves"]:
            v = np.sort(np.asarray(c["values"], float))
            if not v.size:
                continue
            p = 1.0 - np.arange(1, v.size + 1) / v.size
            ax.step(np.r_[v[0], v], np.r_[1.0, p], where="post", color=c.get("color"),
                    ls=c.get("ls", "-"), lw=1.2, label=c.get("label", "_nolegend_"))
        if limit is not None:
            ax.axvline(limit, color="0.15", lw=1.0, ls=":", label=f"limit {limit:g}")
        ax.set_ylim(0.0, 1.02)
        ax.set_ylabel("P(amplification > a) [-]")
        ax.set_title(panel["title"], fontsize=9)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:  # (a member with no complete pattern: none)
            ax.legend(fontsize=7, ncol=2)
    for ax in grid[-1]:
        ax.set_xlabel("a: amplification, worst blade / tuned [-]")
    fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def around_the_disk(path: Path, title: str, peaks: np.ndarray, deviation: np.ndarray
                    ) -> Figure:
    """Every blade's peak over the tuned one (bars, blade by blade around the disk) over its
    stiffness deviation [%] (a line, on its own axis)."""
    fig = _figure((8, 4.2))
    ax = fig.add_subplot()
    blades = np.arange(len(peaks))
    ax.bar(blades, peaks, color="C0", alpha=0.8, label="peak / tuned peak")
    ax.axhline(1.0, color="0.4", ls=":", lw=1.0)
    ax.set_xlabel("blade (around the disk)")
    ax.set_ylabel("peak / tuned peak [-]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    twin = ax.twinx()
    twin.plot(blades, deviation, "o-", color="C3", ms=3, lw=1.0, label="stiffness deviation")
    twin.axhline(0.0, color="C3", lw=0.5, alpha=0.5)
    twin.set_ylabel("Young's modulus deviation [%]", color="C3")
    handles = [*ax.get_legend_handles_labels()[0], *twin.get_legend_handles_labels()[0]]
    ax.legend(handles, [h.get_label() for h in handles], fontsize=8, loc="upper right")
    return _save(fig, path)
