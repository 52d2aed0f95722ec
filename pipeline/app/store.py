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
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5py

from microslip.geometry.stored import written_whole
from microslip.results.writer import signals_held

#: Case tables that do not change what a curve computes.
NEUTRAL = ("title", "description", "analysis")
#: Analysis keys that do not change a curve (naming, drawing, the family itself: its value
#: is in the case variant).
DRAWING_KEYS = ("name", "family", "set", "map_types", "figure")
FORMAT = 1  # bump when the stored layout changes


#: The sources a curve's numbers do not depend on, as dotted module names: the drawing
#: package, the benchmarks and the command line. Every other module of the package counts
#: (COMPUTING): changing one invalidates every stored curve; changing these keeps them.
#: Packages, not file lists, so that a new module is counted without a thought.
COMPUTING = ("microslip",)
NOT_COMPUTING = ("microslip.draw", "microslip.bench", "microslip.cli")
#: The sources of the pictures: the drawing package and the results file it reads.
DRAWING = ("microslip.draw", "microslip.results")
#: The package's folders by dotted name. A source checkout holds two (pipeline/ and
#: geometry/, joined by pyproject's package-dir), an installed wheel one nested folder.
PACKAGES = ("microslip", "microslip.geometry")


def package_folders() -> dict[str, Path]:
    """{dotted name: folder} of PACKAGES where this interpreter imports them from (a
    checkout, an editable install or a wheel in site-packages)."""
    from importlib.util import find_spec

    return {name: Path(next(iter(find_spec(name).submodule_search_locations))).resolve()
            for name in PACKAGES}


def sources(parts: tuple[str, ...], folders: Mapping[str, Path],
            leave_out: tuple[str, ...] = ()) -> dict[str, Path]:
    """{dotted module name: file} of the Python sources under ``parts`` (packages or modules
    by dotted name, e.g. "microslip.fe", "microslip.case.geometry_table"), without those
    under ``leave_out``, found in ``folders`` ({package: folder}), in name order. The names,
    not the paths, identify a module: the same code has the same names in any layout."""
    def under(name: str, prefixes: tuple[str, ...]) -> bool:
        return any(name == x or name.startswith(x + ".") for x in prefixes)

    found: dict[str, Path] = {}
    for package, folder in folders.items():
        for path in Path(folder).glob("**/*.py"):
            name = ".".join((package, *path.relative_to(folder).with_suffix("").parts))
            if under(name, parts) and not under(name, leave_out):
                # (a wheel nests geometry/ in the package: the same file found twice)
                if found.setdefault(name, path).resolve() != path.resolve():
                    raise RuntimeError(f"module {name} in two places: {found[name]}, {path}")
    return dict(sorted(found.items()))


def code_digest(folders: Mapping[str, Path] | None = None,
                parts: tuple[str, ...] = COMPUTING,
                leave_out: tuple[str, ...] = NOT_COMPUTING) -> str:
    """SHA-256 of the sources (module names and contents) of the package (or of the copy in
    ``folders``, as ``package_folders``): by default those a curve's numbers depend on.
    RuntimeError where there are none: a digest of nothing would match any code."""
    folders = package_folders() if folders is None else folders
    found = sources(parts, folders, leave_out)
    if not found:
        raise RuntimeError(f"no Python sources of {parts} in {sorted(map(str, folders.values()))}")
    h = hashlib.sha256()
    for name, path in found.items():
        h.update(name.encode())
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
                  "analysis": {k: v for k, v in analysis.items() if k not in DRAWING_KEYS},
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
            with h5py.File(self._path(key), "r") as f, signals_held():  # whole or not at all
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
        written_whole(self._path(key), lambda f: group.file.copy(group, f, name="curve"))

    def load_row(self, key: str) -> dict[str, Any] | None:
        """A stored row of numbers and texts (:meth:`save_row`), or None."""
        if self.folder is None or not self._path(key).is_file():
            self.misses += 1
            return None
        try:
            with h5py.File(self._path(key), "r") as f:
                row = {k: v.decode() if isinstance(v, bytes) else v
                       for k, v in f["row"].attrs.items()}
        except (OSError, KeyError):
            self.misses += 1
            return None
        self.hits += 1
        return row

    def save_row(self, key: str, row: Mapping[str, Any]) -> None:
        """Keep a row of numbers and texts (a sample of a study), atomically."""
        if self.folder is None:
            return

        def fill(f) -> None:
            g = f.create_group("row")
            for k, v in row.items():
                g.attrs[k] = v

        written_whole(self._path(key), fill)

    def has(self, key: str) -> bool:
        return self.folder is not None and self._path(key).is_file()


class PictureStamps:
    """Which pictures of an analysis are up to date: a stamp per analysis under
    ``<out>/cache/pictures/<name>.json`` holds the key they were drawn from (the keys of its
    curves, the analysis' keys, the drawing code) and their files. A re-run whose curves all
    come from the store, with the same keys, leaves them as they are."""

    def __init__(self, folder: Path | None):
        self.folder = folder

    @staticmethod
    def key(curve_keys: list[str], analysis: Mapping[str, Any]) -> str:
        h = hashlib.sha256(json.dumps([curve_keys, analysis], sort_keys=True,
                                      default=str).encode())
        h.update(code_digest(parts=DRAWING, leave_out=()).encode())
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


def draw_once(draw, group: h5py.Group, spec, out: Path, progress, keys: list[str] = (),
              cached: bool = False) -> None:
    """Draw an analysis' pictures (``draw``: a ``pictures`` drawer), unless every curve came
    from the store (``cached``) and the pictures drawn from the same ``keys`` are all there
    (PictureStamps)."""
    stamps = PictureStamps(out / "cache" / "pictures")
    key = stamps.key(list(keys), spec.table())
    kept = stamps.current(spec.name, key) if cached else None
    if kept is None:
        kept = draw(group, spec.name, out)
        stamps.remember(spec.name, key, kept)
    else:
        progress(f"[{spec.name}] pictures unchanged ({len(kept)} files)")
    # the pictures' names with the analysis: the folder's page takes them from there
    group.attrs["pictures"] = json.dumps([Path(p).name for p in kept])
