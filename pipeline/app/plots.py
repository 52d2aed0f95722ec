"""PNG pictures of a run (matplotlib, headless): FRFs and families of FRFs,
parameter curves (optimization and performance plots), hysteresis loops and 2D
force trajectories, time integration against harmonic balance."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

LABELS = {
    "frequency": "excitation frequency w [rad/s]",
    "excitation": "excitation multiplier [-]",
    "preload": "preload multiplier (N0 when n0 = 1 N) [-]",
    "mass": "mass multiplier [-]",
}


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def curves(path: Path, title: str, xlabel: str, series: Sequence[dict], ylabel: str,
           *, logx: bool = False, logy: bool = False, markers: Sequence[dict] = ()) -> Path:
    """Lines ``{x, y, label}`` (turning points marked where given) and point sets
    ``{x, y, label}`` drawn as markers (time integration)."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for s in series:
        (line,) = ax.plot(s["x"], s["y"], label=s.get("label"), lw=s.get("lw", 1.4),
                          ls=s.get("ls", "-"), color=s.get("color"))
        tp = s.get("turning_points", [])
        if len(tp):
            ax.plot(np.asarray(s["x"])[tp], np.asarray(s["y"])[tp], "o", mfc="none",
                    color=line.get_color(), ms=6)
    for m in markers:
        ax.plot(m["x"], m["y"], m.get("style", "ks"), label=m.get("label"), ms=5, mfc="none")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    if logx:
        ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    ax.grid(alpha=0.3)
    if any(s.get("label") for s in list(series) + list(markers)):
        ax.legend(fontsize=8)
    return _save(fig, path)


def loops(path: Path, title: str, loops_: Sequence[dict], *, two_d: bool) -> Path:
    """Hysteresis loops T(u) (1D, with N(t) dashed when it varies) or force
    trajectories (T_x, T_y) with the Coulomb circle (2D)."""
    fig, ax = plt.subplots(figsize=(6, 5))
    for lp in loops_:
        if two_d:
            T = np.asarray(lp["T"])
            (line,) = ax.plot(np.append(T[0], T[0, 0]), np.append(T[1], T[1, 0]),
                              label=lp["label"])
            lim = np.max(lp["limit"])
            th = np.linspace(0, 2 * np.pi, 200)
            ax.plot(lim * np.cos(th), lim * np.sin(th), ":", color=line.get_color(), lw=0.8)
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
    ax.legend(fontsize=8)
    return _save(fig, path)


def transient(path: Path, title: str, steps: Sequence[dict]) -> Path:
    """Load steps (seed Fig. 13): per step, the outputs over time (top) and a
    contact's tangential force with the limits +-mu N (bottom)."""
    fig, axes = plt.subplots(2, len(steps), figsize=(6 * len(steps), 6.5), squeeze=False)
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
        ax.plot(st["t"], st["limit"], "k--", lw=0.8, label="+- mu N")
        ax.plot(st["t"], -st["limit"], "k--", lw=0.8)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"contact {st['contact']} [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return _save(fig, path)
