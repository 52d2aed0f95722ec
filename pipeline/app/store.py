"""Computed curves kept between runs: a re-run recomputes only what changed.

Each curve an analysis computes (an FRF branch with its maps, a linear limit, a peak curve)
is a pure function of the case variant that produced it (the case with the analysis' ``set``
and family value applied), of the analysis' own keys and of the code. Its results.h5 group is
stored under ``<out>/cache/curves/<key>.h5``, the key a SHA-256 of those inputs (the code by a
digest of the sources the numbers depend on, COMPUTING: any change there invalidates every
curve).
Only finished curves are stored (complete, or stopped for a reason a re-run would meet
again); an interrupted one is computed again. The files are HDF5, safe to open.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py

#: Case tables that do not change what a curve computes.
NEUTRAL = ("title", "description", "analysis")
#: Analysis keys that do not change a curve (naming, drawing, the family itself: its value
#: is in the case variant).
DRAWING = ("name", "family", "set", "map_types")
FORMAT = 1  # bump when the stored layout changes


#: The sources a curve's numbers depend on (relative to the package root): the geometry,
#: the numerical stages, and the application modules that build the models and curves.
#: Pictures, plans, benchmarks and the command line are left out: changing them keeps the
#: stored curves.
COMPUTING = ("geometry", "pipeline/fe", "pipeline/friction", "pipeline/solve",
             "pipeline/coupling", "pipeline/app/case.py", "pipeline/app/coupled.py",
             "pipeline/app/models.py", "pipeline/app/run.py", "pipeline/app/structure.py",
             "pipeline/app/solutions.py", "pipeline/app/limits.py",
             "pipeline/app/checks.py", "pipeline/app/store.py")


def code_digest(root: Path | None = None) -> str:
    """SHA-256 of the sources in COMPUTING (file names and contents) under the package's
    root (or ``root``)."""
    root = root or Path(__file__).resolve().parents[2]
    h = hashlib.sha256()
    for part in COMPUTING:
        paths = [root / part] if part.endswith(".py") else sorted((root / part).glob("**/*.py"))
        for path in paths:
            h.update(str(path.relative_to(root)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()


class CurveStore:
    """The curves of one output folder. ``folder`` None: a store that keeps nothing."""

    def __init__(self, folder: Path | None, code: str | None = None):
        self.folder = folder
        self.code = code if code is not None else (code_digest() if folder else "")
        self.hits = 0
        self.misses = 0

    def key(self, data: Mapping[str, Any], analysis: Mapping[str, Any],
            **extra: Any) -> str:
        """The key of a curve: the case variant's computing tables, the analysis' computing
        keys and ``extra`` (method, family value, what is computed)."""
        inputs = {"case": {k: v for k, v in data.items() if k not in NEUTRAL},
                  "analysis": {k: v for k, v in analysis.items() if k not in DRAWING},
                  "extra": extra, "code": self.code, "format": FORMAT}
        text = json.dumps(inputs, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:32]

    def _path(self, key: str) -> Path:
        assert self.folder is not None
        return self.folder / f"{key}.h5"

    def load(self, key: str, parent: h5py.Group, name: str) -> bool:
        """Copy a stored curve into ``parent[name]``; False if there is none (or it cannot
        be read: it is then computed again)."""
        if self.folder is None or not self._path(key).is_file():
            self.misses += 1
            return False
        try:
            with h5py.File(self._path(key), "r") as f:
                f.copy(f["curve"], parent, name=name)
        except (OSError, KeyError):
            self.misses += 1
            return False
        self.hits += 1
        return True

    def save(self, key: str, group: h5py.Group) -> None:
        """Keep a written curve group (atomically: a partial file is never read)."""
        if self.folder is None:
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = self._path(key).with_suffix(".tmp")
        with h5py.File(tmp, "w") as f:
            group.file.copy(group, f, name="curve")
        os.replace(tmp, self._path(key))

    def has(self, key: str) -> bool:
        return self.folder is not None and self._path(key).is_file()


#: The sources of the pictures (relative to the package root).
DRAWING_SOURCES = ("pipeline/app/pictures.py", "pipeline/app/maps.py", "pipeline/app/plots.py")


class PictureStamps:
    """Which pictures of an analysis are up to date: a stamp per analysis under
    ``<out>/cache/pictures/<name>.json`` holds the key they were drawn from (the keys of its
    curves, the analysis' keys, the drawing code) and their files. A re-run whose curves all
    come from the store, with the same keys, leaves them as they are."""

    def __init__(self, folder: Path | None):
        self.folder = folder

    @staticmethod
    def key(curve_keys: list[str], analysis: Mapping[str, Any]) -> str:
        root = Path(__file__).resolve().parents[2]
        h = hashlib.sha256(json.dumps([curve_keys, analysis], sort_keys=True,
                                      default=str).encode())
        for part in DRAWING_SOURCES:
            h.update((root / part).read_bytes())
        return h.hexdigest()[:32]

    def current(self, name: str, key: str) -> list[Path] | None:
        """The pictures drawn from ``key``, if they are all still there."""
        if self.folder is None or not (self.folder / f"{name}.json").is_file():
            return None
        try:
            stamp = json.loads((self.folder / f"{name}.json").read_text())
        except (OSError, ValueError):
            return None
        out = self.folder.parents[1]  # <out>/cache/pictures
        paths = [out / p for p in stamp.get("files", [])]
        if stamp.get("key") != key or not paths or not all(p.is_file() for p in paths):
            return None
        return paths

    def remember(self, name: str, key: str, paths: list[Path]) -> None:
        if self.folder is None:
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        (self.folder / f"{name}.json").write_text(
            json.dumps({"key": key, "files": [Path(p).name for p in paths]}))
