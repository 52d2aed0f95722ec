"""``results.h5``: what a run computed, safe to open (HDF5 via h5py, no pickle).

The names and layout are :mod:`.schema`'s (the README shows them).

The file is written under a temporary name and renamed when closed, so a
results file is never half written; a run that stops early (Ctrl-C, an error)
still renames what it finished, marked ``partial`` or ``failed``.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import json
import os
import platform
import re
import shutil
import signal
import threading
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import h5py
import numpy as np

from . import schema


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    import numba
    import scipy

    try:
        own = version("microslip")
    except PackageNotFoundError:
        own = "unknown"
    return {"microslip": own, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "numba": numba.__version__, "h5py": h5py.__version__}


def _attr(value):
    """A value as an HDF5 attribute: tables and lists but numeric ones as JSON text
    (:func:`attr_value` reads it back)."""
    if isinstance(value, (dict, list, tuple)) and not (
            isinstance(value, (list, tuple)) and value and all(
                isinstance(v, (int, float)) for v in value)):
        return json.dumps(value, default=str)
    if value is None:
        return ""
    return value


def set_attrs(g: h5py.HLObject, attrs: Mapping) -> None:
    """Attributes written as ``ResultsWriter.write_group`` writes them."""
    for k, v in attrs.items():
        g.attrs[k] = _attr(v)


def attr_text(value) -> str:
    """An attribute as text (h5py gives bytes or str)."""
    return value.decode() if isinstance(value, bytes) else str(value)


def attr_value(value):
    """An attribute as :func:`_attr` wrote it, back in TOML form: JSON text as tables and
    lists, numpy scalars and arrays as Python numbers and lists."""
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str) and value.startswith(("[", "{")):
        return json.loads(value)
    if isinstance(value, np.ndarray):
        return [attr_value(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    return value


def attr_table(attrs) -> dict:
    """Every attribute of a group (``h5py`` attrs), read back by :func:`attr_value`."""
    return {k: attr_value(attrs[k]) for k in attrs}


#: The errors of a full disk (or an exhausted quota).
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)


#: Room a results-file write leaves free on its disk beyond twice its data [bytes]: HDF5
#: writes metadata as it goes, and meeting a full disk mid-write corrupts its state (closing
#: the file then fails, or crashes the process), so a write that would leave less stops
#: before HDF5 starts it, as a full disk does (``_room``).
DISK_MARGIN = 128 * 1024


def is_disk_full(err: BaseException) -> bool:
    """Whether ``err`` is a full disk or quota (h5py reports some as RuntimeError with the
    C library's errno in its text)."""
    if isinstance(err, OSError) and err.errno in DISK_FULL:
        return True
    text = str(err)
    return isinstance(err, (OSError, RuntimeError)) and any(
        f"errno = {n}," in text for n in DISK_FULL)


def _room(h5: h5py.File, nbytes: int) -> None:
    """OSError (ENOSPC) unless the disk of ``h5`` has room for ``nbytes`` of data (see
    DISK_MARGIN)."""
    folder = Path(h5.filename).parent
    free = shutil.disk_usage(folder).free
    if free < 2 * nbytes + DISK_MARGIN:
        raise OSError(errno.ENOSPC, f"no space left on the device: {free:,} bytes free, "
                      f"{nbytes:,} to write", h5.filename)


def _nbytes(datasets: Mapping) -> int:
    """The bytes of the arrays of a nested mapping of datasets."""
    total = 0
    for k, v in datasets.items():
        if k == ATTRS:
            continue
        total += _nbytes(v) if isinstance(v, Mapping) else np.asarray(v).nbytes
    return total


class ResultsWriter:
    """Context manager writing ``path`` atomically (``path.tmp`` then rename).

    When the disk fills, the curve being written is dropped (write_group), ``on_disk_full``
    is called (to give back reserved space: ``app.folder``) and the file is closed
    ``partial`` with every finished curve; the error is raised again."""

    def __init__(self, path: str | Path, *, title: str, source: str, case_hash: str,
                 case: Mapping, on_disk_full: Callable[[], None] | None = None):
        self.on_disk_full = on_disk_full
        self.path = Path(path)
        self.tmp = self.path.with_name(self.path.name + ".tmp")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.file = h5py.File(self.tmp, "w")
        root = self.file.attrs
        root["title"] = title
        root["source"] = str(source)
        root["case_hash"] = case_hash
        root["status"] = "partial"
        root["message"] = ""
        root["created"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
        root["versions"] = json.dumps(versions())
        self.file.create_group(schema.CASE).attrs["json"] = json.dumps(case, default=str)

    def __enter__(self) -> ResultsWriter:
        return self

    def analysis(self, name: str, attrs: Mapping) -> h5py.Group:
        _room(self.file, 0)
        g = self.file.create_group(name)
        for k, v in attrs.items():
            g.attrs[k] = _attr(v)
        g.attrs["status"] = "partial"
        return g

    @staticmethod
    def write_group(parent: h5py.Group, name: str, datasets: Mapping, attrs: Mapping) -> None:
        """One curve: datasets (arrays, or nested mappings as subgroups) and attrs; whole
        or not at all (signals_held)."""
        _room(parent.file, _nbytes(datasets))
        with signals_held():
            try:
                g = parent.create_group(name)
                for k, v in attrs.items():
                    g.attrs[k] = _attr(v)
                _datasets(g, datasets)
            except BaseException:  # (a full disk): no half-written curve stays in the file
                with contextlib.suppress(Exception):
                    del parent[name]
                raise

    def flush(self) -> None:
        _room(self.file, 0)
        self.file.flush()

    def close(self, status: str, message: str = "") -> Path:
        self.file.attrs["status"] = status
        self.file.attrs["message"] = message
        self.file.close()
        os.replace(self.tmp, self.path)
        return self.path

    def __exit__(self, kind, err, tb) -> bool:
        if not self.file:  # already closed
            return False
        if kind is None:
            self.close("complete")
        elif issubclass(kind, KeyboardInterrupt):
            self.close("partial", "interrupted by the user")
        elif is_disk_full(err):
            if self.on_disk_full is not None:
                self.on_disk_full()
            self.close("partial", "no space left on the device: the run stopped there")
        else:
            self.close("failed", f"{kind.__name__}: {err}")
        return False


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Ctrl-C (SIGINT) and SIGTERM held for the duration, then handled as they would have
    been: a curve is written whole or not at all. (A run that waits on a cluster spends its
    time between writes, but a Ctrl-C landing inside one left a group without its datasets,
    which the pictures and ``show`` could not read.) Only the main thread receives signals;
    elsewhere nothing is held."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[tuple[int, object]] = []
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    for s in previous:
        signal.signal(s, lambda signum, frame: held.append((signum, frame)))
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if held:
            signum, frame = held[0]
            handler = previous[signum]
            if callable(handler):  # Python's KeyboardInterrupt, or run's Terminated
                handler(signum, frame)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), signum)


#: A key of a nested mapping given to ``write_group`` whose value (a mapping) becomes the
#: attributes of that subgroup rather than a dataset.
ATTRS = "__attrs__"


def _datasets(g: h5py.Group, datasets: Mapping) -> None:
    for k, v in datasets.items():
        if k == ATTRS:
            for name, value in v.items():
                g.attrs[name] = _attr(value)
        elif isinstance(v, Mapping):
            _datasets(g.create_group(k), v)
        else:
            arr = np.asarray(v)
            if arr.dtype.kind in "UO":
                arr = arr.astype("S")
            g.create_dataset(k, data=arr)


class ResultsError(ValueError):
    """A path that is not a readable results file; the message names it and why."""

    def __init__(self, path: str | Path, reason: str):
        self.reason = reason
        super().__init__(f"{path}: {reason}")


ROOT_ATTRS = ("title", "source", "case_hash", "status", "message", "created", "versions")


def open_results(path: str | Path, *, locking: bool = True) -> h5py.File:
    """A results file opened for reading; ResultsError if it is not one.

    locking=False reads a file another process may still hold open for writing (a run's
    ``results.h5.tmp``), which HDF5's file locking would otherwise refuse.
    """
    try:
        f = h5py.File(path, "r", locking=locking)
    except OSError as err:
        raise ResultsError(path, f"cannot open as HDF5 ({_reason(err)})") from None
    missing = [k for k in ROOT_ATTRS if k not in f.attrs]
    if missing:
        f.close()
        raise ResultsError(path, "an HDF5 file but not a microslip results file (no root "
                           f"attribute {', '.join(missing)})")
    return f


#: Top-level groups of a results file that are not analyses.
NOT_ANALYSES = (schema.CASE, schema.GEOMETRY, schema.CONTACT_GRIDS, schema.SURFACES,
                schema.REDUCTION)


def analysis_names(path: str | Path) -> list[str]:
    """The analyses a results file holds, in its order; ResultsError if it is not one."""
    with open_results(path) as f:
        return [k for k in f if k not in NOT_ANALYSES]


def _reason(err: OSError) -> str:
    """h5py's open errors, shortened to what a user can act on."""
    if err.errno:
        return os.strerror(err.errno)
    text = str(err)
    if "signature not found" in text:
        return "not an HDF5 file"
    inner = re.search(r"\(([^()]*)\)\s*$", text)  # HDF5's own reason, in the last (...)
    return inner.group(1) if inner else text


def summary(path: str | Path) -> str:
    """A readable summary of a results file (``microslip show``); ResultsError if the
    path is not one."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.h5"
    with open_results(path) as f:
        a = f.attrs
        lines = [f"{a['title']}  [{a['status']}]  {a['message']}".rstrip(),
                 f"  source {a['source']}, case {a['case_hash'][:12]}, {a['created']}"]
        v = json.loads(a["versions"])
        lines.append("  " + ", ".join(f"{k} {v[k]}" for k in sorted(v)))
        lines.extend(_analysis_lines(f))
    return "\n".join(lines)


def leftover(tmp: str | Path) -> str:
    """What a ``results.h5.tmp`` holds: the file of a run killed before it could rename it
    (SIGKILL, power loss), or of a run still going."""
    tmp = Path(tmp)
    head = (f"{tmp}: left by a run that was killed before it finished, or is still running "
            f"(never renamed to {tmp.name.removesuffix('.tmp')})")
    try:
        with open_results(tmp, locking=False) as f:
            lines = _analysis_lines(f)
    except ResultsError as err:
        return f"{head}; unreadable: {err.reason}"
    except Exception as err:  # a killed writer can leave any inconsistency: report, not fail
        return f"{head}; unreadable: {type(err).__name__}: {err}"
    if not lines:
        return f"{head}; it holds no analysis yet"
    return f"{head}; it holds:\n" + "\n".join("  " + x for x in lines)


def _analysis_lines(f: h5py.File) -> list[str]:
    """Per analysis: type, status, time; per curve: points, status, largest amplitude."""
    lines = []
    for name, g in f.items():
        if name in (schema.CASE, schema.CONTACT_GRIDS):
            continue
        if name == schema.SURFACES:  # what the previews and shape pictures draw on
            lines.append("surfaces (of the previews and shapes): " + ", ".join(
                f"{b} {sg['nodes'].shape[0]} nodes" for b, sg in g.items()))
            continue
        ga = g.attrs
        lines.append(f"{name}: {ga.get('type', '?')} [{ga.get('status', '?')}] "
                     f"{ga.get('elapsed_s', 0.0):.2f} s {ga.get('message', '')}".rstrip())
        if ga.get("type") == "reduction":
            lines.extend(_reduction_lines(g))
            continue
        if ga.get("type") == "geometry":  # its cyclic faces are no curves
            continue
        if ga.get("type") == "uncertainty":
            lines.extend(_uncertainty_lines(g))
            continue
        if ga.get("type") == "modes":
            lines.extend(_modes_lines(g))
            continue
        if ga.get("type") == "mistuning":
            lines.extend(_mistuning_lines(g))
            continue
        for curve, c in g.items():
            if not isinstance(c, h5py.Group):
                continue
            ca = c.attrs
            npts = next((c[k].shape[0] for k in ("parameter", "omega", "amplitude", "t")
                         if k in c), 0)
            extra = ""
            if "amplitude" in c and c["amplitude"].size:
                extra = f", max amplitude {np.max(c['amplitude'][()]):.6g}"
            label = f" {ca['label']}" if ca.get("label", "") else ""
            lines.append(f"  {curve}{label}: {npts} points "
                         f"[{ca.get('status', '?')}]{extra} {ca.get('message', '')}".rstrip())
            coarse = sampling_warning(c)
            if coarse:
                lines.append(f"    warning: {coarse}")
    return lines


def _modes_lines(g: h5py.Group) -> list[str]:
    """A modes analysis: per body and nodal diameter its first frequencies and the reduced
    model's largest error; per harmonic the reduced assembly's stuck and free frequencies."""
    def first(f) -> str:
        return " ".join(f"{x:.6g}" for x in f[()][:6])

    lines = []
    for body, b in g.items():
        for where, m in b.items():
            if body == schema.ASSEMBLY_MODES:
                lines.append(f"  assembly, harmonic {m.attrs['order']}: stuck f [Hz] "
                             f"{first(m['stuck_hz'])}; free {first(m['free_hz'])}")
                continue
            error = float(np.abs(m["relative_error"][()]).max(initial=0.0))
            lines.append(f"  {body} {where}: f [Hz] {first(m['frequencies_hz'])}; reduced "
                         f"model's error at most {error:.2g}")
    return lines


def _uncertainty_lines(g: h5py.Group) -> list[str]:
    """An uncertainty study: its samples and the percentiles of their peaks."""
    if schema.SAMPLES not in g or schema.STATISTICS not in g:
        return []
    s, st = g[schema.SAMPLES], g[schema.STATISTICS]
    status = s["status"][()]
    p5, p50, p95 = st["percentiles"][()]
    line = (f"  {status.size} samples ({np.count_nonzero(status == b'complete')} complete): "
            f"peak 5 % {p5:.6g}, median {p50:.6g}, 95 % {p95:.6g}")
    limit = float(st.attrs.get("limit", np.nan))
    if np.isfinite(limit):
        line += f"; P(peak > {limit:g}) = {float(st.attrs['exceedance']):.3f}"
    return [line]


def _mistuning_lines(g: h5py.Group) -> list[str]:
    """A mistuning study: per member (one without a family) its patterns and, per level,
    the amplification's median and largest with the dampers (and without), and with a
    limit P(A > limit) and the count it is of."""
    lines = []
    for label, m in schema.mistuning_members(g):
        if schema.AMPLIFICATION not in m:
            continue
        p, a = m[schema.PATTERNS], m[schema.AMPLIFICATION]
        status = p["status"][()]
        pre = f"  {label}: " if label else "  "
        lines.append(f"{pre}{status.size} patterns ({np.count_nonzero(status == b'complete')} "
                     f"complete); tuned peak {float(p.attrs['tuned_peak']):.6g} m; Whitehead "
                     f"{float(a.attrs['whitehead']):.3f}")
        limit = float(a.attrs.get("limit", np.nan))
        for k, sigma in enumerate(a["sigma"][()]):
            parts = [f"{case} median {a[f'{case}_percentiles'][k, 1]:.3f}, largest "
                     f"{a[f'{case}_largest'][k]:.3f}" + (
                         f", P(A > {limit:g}) {a[f'{case}_exceedance'][k]:.3f} of "
                         f"{a[f'{case}_count'][k]}" if np.isfinite(limit) else "")
                     for case in ("friction", "free") if f"{case}_percentiles" in a]
            lines.append(f"{pre}sigma {sigma:g}: amplification " + "; ".join(parts))
    return lines


#: The largest first-order change a curve may show when its period is sampled twice as
#: finely before ``run`` and ``show`` warn: 0.1 % of the response (the figures are given to
#: four digits), or 0.1 % of the parameter's range in the parameter (a shift of the curve).
SAMPLING_TOL = 1e-3


def sampling_warning(c: h5py.Group) -> str:
    """What ``run`` and ``show`` say of an FRF curve that depends on its time sampling: its
    contacts' stick arcs fall within two samples at some points (``undersampled``) and
    there, sampled twice as finely, the curve moves (``sampling_change`` of the response,
    ``sampling_shift`` of the parameter, first order) by more than SAMPLING_TOL. "" where
    it does not (a stick arc between samples, located by the sub-sample transitions, often
    costs nothing)."""
    if "sampling_change" not in c or not c["sampling_change"].size:
        return ""
    par, samples = c["parameter"][()], int(c.attrs.get("samples", 0))
    span = float(np.ptp(par)) or 1.0
    change, shift = c["sampling_change"][()], c["sampling_shift"][()]
    moved = np.fmax(change, np.abs(shift) / span)
    if not np.nanmax(moved, initial=0.0) > SAMPLING_TOL:
        return ""
    i = int(np.nanargmax(moved))
    flagged = {k: p["undersampled"][()] > 0 for k, p in c[schema.CONTACTS].items()
               if isinstance(p, h5py.Group) and "undersampled" in p}
    which = [k for k, f in flagged.items() if f.any()]
    points = int(np.logical_or.reduce([flagged[k] for k in which]).sum())
    name = str(c.parent.attrs.get("parameter", "frequency"))
    return (f"sampled twice as finely, the curve moves by {100 * change[i]:.2g} % of the "
            f"response ({name} by {shift[i]:.3g}) at {name} = {par[i]:.6g}: stick arcs within "
            f"two of the {samples:,} samples per period at {points} of {len(par)} points "
            f"(contact{'s' if len(which) > 1 else ''} {', '.join(which)}); raise "
            f"harmonics.samples from {samples:,}, e.g. to {4 * samples:,}")


def _reduction_lines(g: h5py.Group) -> list[str]:
    """Per body and ND: model size and the first natural frequencies of the reduced model."""
    nds = [int(h) for h in g.attrs["nodal_diameters"]]
    lines = [f"  nodal diameters {nds}, {len(json.loads(g.attrs['cached']))} models from the "
             "cache"]
    for body, b in g.items():
        if body == schema.CONTACT_STIFFNESS:
            for patch, p in b.items():
                lines.append(f"  contact {patch}: kn {np.sum(p['normal_n_per_m'][()]):.4g} N/m, "
                             f"kt {np.sum(p['tangential_n_per_m'][()]):.4g} N/m over "
                             f"{p['normal_n_per_m'].size} node pairs")
            continue
        for nd, m in sorted(b.items(), key=lambda item: int(item[0][2:])):
            f = " ".join(f"{x:.0f}" for x in m["frequencies_hz"][()][:7])
            lines.append(f"  {body} {nd}: {m.attrs['n_master_dofs']} master DOFs + "
                         f"{m.attrs['n_modes']} modes; f [Hz] {f}")
    return lines
