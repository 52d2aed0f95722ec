"""Two results files compared, dataset by dataset and attribute by attribute
(``microslip compare``): did a change of code, version or machine move any number?

A numerical dataset agrees when its shape is the same and max |b - a| <= rtol max |a| (the
difference measured against the dataset's largest entry: an entry near zero in a dataset of
large ones is not held to 1e-12 of itself); NaN agrees with NaN only. Text and integer data
agree when equal. What records when, where and how fast a run happened (VOLATILE) is not
compared. Datasets and attributes only in the new file are additions: listed, but every
number of the old file is still there and the same, so they do not make the files differ.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

#: Attributes and datasets that record the run, not its numbers: when, with which versions,
#: how long (elapsed_s, a time integration's or a sample's seconds), the messages that quote
#: those times, and which reduced models came from the cache
VOLATILE = frozenset({"created", "versions", "elapsed_s", "message", "seconds", "cached"})


@dataclass(frozen=True)
class Difference:
    """One disagreement: the HDF5 path (attribute as path@name), what differs, and the
    relative size of a numerical difference (NaN for a structural one). ``added``: only in
    the new file (not a difference of the old numbers)."""

    path: str
    what: str
    relative: float = float("nan")
    added: bool = False


def results_path(path: str | Path) -> Path:
    """A results file given as itself or as the output folder holding results.h5."""
    path = Path(path)
    return path / "results.h5" if path.is_dir() else path


def differences(old: str | Path, new: str | Path, rtol: float = 1e-12) -> list[Difference]:
    """Every disagreement between two results files (empty: the same numbers)."""
    with h5py.File(results_path(old), "r") as a, h5py.File(results_path(new), "r") as b:
        return list(_group(a, b, rtol))


def _group(a: h5py.Group, b: h5py.Group, rtol: float) -> Iterator[Difference]:
    yield from _attributes(a, b, rtol)
    for name in sorted((set(a) | set(b)) - VOLATILE):
        path = f"{a.name.rstrip('/')}/{name}"
        if name not in b:
            yield Difference(path, "only in the old file")
        elif name not in a:
            yield Difference(path, "only in the new file", added=True)
        elif isinstance(a[name], h5py.Group) != isinstance(b[name], h5py.Group):
            yield Difference(path, "a group in one file, a dataset in the other")
        elif isinstance(a[name], h5py.Group):
            yield from _group(a[name], b[name], rtol)
        else:
            yield from _attributes(a[name], b[name], rtol)
            found = _values(path, a[name][()], b[name][()], rtol)
            if found:
                yield found


def _attributes(a: h5py.HLObject, b: h5py.HLObject, rtol: float) -> Iterator[Difference]:
    base = a.name.rstrip("/")
    for key in sorted((set(a.attrs) | set(b.attrs)) - VOLATILE):
        path = f"{base}@{key}"
        if key not in b.attrs:
            yield Difference(path, "only in the old file")
        elif key not in a.attrs:
            yield Difference(path, "only in the new file", added=True)
        else:
            found = _values(path, a.attrs[key], b.attrs[key], rtol)
            if found:
                yield found


def _values(path: str, a, b, rtol: float) -> Difference | None:
    """The disagreement of two values (scalars, arrays, text), or None."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        return Difference(path, f"shape {a.shape} against {b.shape}")
    numeric = (np.issubdtype(a.dtype, np.number) and np.issubdtype(b.dtype, np.number)
               and not np.issubdtype(a.dtype, np.integer))
    if not numeric:
        if np.array_equal(a, b):
            return None
        return Difference(path, f"{_short(a)} against {_short(b)}")
    nan_a, nan_b = np.isnan(a), np.isnan(b)
    if not np.array_equal(nan_a, nan_b):
        return Difference(path, "NaN at different entries")
    if not a.size or nan_a.all():
        return None
    gap = np.abs(b - a)[~nan_a]
    if np.any(~np.isfinite(gap)):
        same_inf = np.array_equal(a[~nan_a], b[~nan_a])
        return None if same_inf else Difference(path, "Inf at different entries")
    scale = float(np.max(np.abs(a[~nan_a])))
    relative = float(np.max(gap)) / scale if scale > 0 else float(np.max(gap))
    if relative <= rtol:
        return None
    return Difference(path, f"max |new - old| = {relative:.3g} of max |old|", relative)


def _short(value: np.ndarray) -> str:
    text = repr(value.tolist() if value.ndim else value.item())
    return text if len(text) <= 60 else text[:57] + "..."


def report(old: str | Path, new: str | Path, rtol: float = 1e-12, shown: int = 20
           ) -> tuple[bool, str]:
    """(same, text): whether every number of the old file is in the new one and agrees, and
    the lines for the terminal (the differences first, then the additions)."""
    found = differences(old, new, rtol)
    changed = [d for d in found if not d.added]
    added = [d for d in found if d.added]
    head = f"{results_path(old)} against {results_path(new)}, rtol {rtol:g}"
    verdict = (f"{len(changed)} difference(s)" if changed else "the same numbers")
    lines = [f"{head}: {verdict}" + (f", {len(added)} addition(s)" if added else "")]
    for d in (changed + added)[:shown]:
        lines.append(f"  {d.path}: {d.what}")
    if len(found) > shown:
        lines.append(f"  ... and {len(found) - shown} more")
    return not changed, "\n".join(lines)
