"""The cache every run of this user shares: meshes and reduced models, keyed by content.

A case copied to change a friction coefficient needs the same mesh and the same reduced
models as the original; they were kept per output folder, so the copy reduced its 80 s of
models again. Now they live in one folder for all runs:

- where: ``$MICROSLIP_CACHE`` if set, else the platform's cache folder
  (``$XDG_CACHE_HOME/microslip`` or ``~/.cache/microslip`` on Linux,
  ``~/Library/Caches/microslip`` on macOS, ``%LOCALAPPDATA%\\microslip\\cache`` on Windows);
- what: ``meshes/mesh-<key>.h5`` (a parametric model's Gmsh mesh, keyed by the model, its
  parameters and contacts, the geometry code and the Gmsh version) and
  ``models/cb-<key>.h5`` (a body's Craig-Bampton model at one nodal diameter, keyed by
  everything that produced it: ``fe.reduced_model``); HDF5 both, never pickle;
- how much: at most ``$MICROSLIP_CACHE_SIZE`` (e.g. ``20GB``, ``500MB``; default 10 GB):
  after a run, the least recently used files go until the rest fit (never those the run
  used); ``microslip cache`` shows it and ``microslip cache --clear`` empties it.

A file is written under a temporary name and renamed, so two runs sharing the cache at once
never read a half-written file (the worst is one computed twice).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

ENV = "MICROSLIP_CACHE"
ENV_SIZE = "MICROSLIP_CACHE_SIZE"
DEFAULT_SIZE = 10 * 10**9  # bytes: the models of a few full-scale studies
KINDS = ("meshes", "models")
PART_AGE_S = 3600.0  # a part file this recent may be another run's write in progress
_UNITS = {"": 1, "B": 1, "KB": 10**3, "MB": 10**6, "GB": 10**9, "TB": 10**12,
          "KIB": 2**10, "MIB": 2**20, "GIB": 2**30, "TIB": 2**40}


class CacheSettingError(ValueError):
    """A cache setting (environment variable) that cannot be used: one line naming it."""


def default_root() -> Path:
    """The platform's cache folder for microslip (see the module)."""
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "microslip"
    if os.name == "nt":
        base = os.environ.get("LOCALAPPDATA") or str(Path.home() / "AppData" / "Local")
        return Path(base) / "microslip" / "cache"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "microslip"


def size_bytes(text: str) -> int:
    """Bytes of a size such as ``10GB``, ``500 MB``, ``2GiB`` or ``123456``."""
    t = text.strip().upper().replace(" ", "")
    digits = t.rstrip("KMGTIB")
    unit = t[len(digits):]
    try:
        value = float(digits)
    except ValueError:
        value = -1.0
    if unit not in _UNITS or not (value >= 0 and math.isfinite(value)):
        raise CacheSettingError(f"{ENV_SIZE} = {text!r}: expected a size such as 10GB, 500MB "
                                "or a number of bytes")
    return int(value * _UNITS[unit])


@dataclass(frozen=True)
class SharedCache:
    """The cache at ``root`` holding at most ``limit`` bytes (see the module)."""

    root: Path
    limit: int = DEFAULT_SIZE

    @classmethod
    def from_environment(cls) -> SharedCache:
        """The cache the environment names (or the platform's); CacheSettingError for a
        setting that cannot be used."""
        given = os.environ.get(ENV, "").strip()
        root = Path(given).expanduser() if given else default_root()
        size = os.environ.get(ENV_SIZE, "").strip()
        return cls(root, size_bytes(size) if size else DEFAULT_SIZE)

    @property
    def meshes(self) -> Path:
        return self.root / "meshes"

    @property
    def models(self) -> Path:
        return self.root / "models"

    def check_writable(self) -> str:
        """"" if the cache folder can be written, else why not (one phrase)."""
        try:
            for kind in KINDS:
                (self.root / kind).mkdir(parents=True, exist_ok=True)
            probe = self.root / f".probe-{os.getpid()}"
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as err:
            return f"{ENV} = {self.root}: cannot write there ({err.strerror})"
        return ""

    def files(self) -> list[Path]:
        """Every kept file (meshes and models)."""
        return [p for kind in KINDS if (self.root / kind).is_dir()
                for p in (self.root / kind).iterdir() if p.suffix == ".h5"]

    def usage(self) -> dict[str, tuple[int, int]]:
        """kind -> (files, bytes)."""
        files = self.files()
        out = {}
        for kind in KINDS:
            found = [p for p in files if p.parent.name == kind]
            out[kind] = (len(found), sum(_size(p) for p in found))
        return out

    @staticmethod
    def used(paths: Iterable[Path]) -> None:
        """Mark files as just used (their modification time: the least recently used go
        first when the cache is over its bound)."""
        now = time.time()
        for p in paths:
            with contextlib.suppress(OSError):
                os.utime(p, (now, now))

    def prune(self, keep: Iterable[Path] = ()) -> tuple[int, int]:
        """Remove the least recently used files until the rest fit the bound, never those in
        ``keep``; (files, bytes) removed."""
        keep = {Path(p).resolve() for p in keep}
        entries = sorted(((_mtime(p), _size(p), p) for p in self.files()),
                         key=lambda e: e[0])
        total = sum(size for _, size, _ in entries)
        removed = [0, 0]
        for _, size, path in entries:
            if total <= self.limit:
                break
            if path.resolve() in keep:
                continue
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
                removed[0] += 1
                removed[1] += size
                total -= size
        return removed[0], removed[1]

    def clear(self) -> tuple[int, int]:
        """Remove every kept file (and leftovers of interrupted writes, but not a write in
        progress: a part file younger than PART_AGE_S); (files, bytes)."""
        removed = [0, 0]
        recent = time.time() - PART_AGE_S
        for kind in KINDS:
            folder = self.root / kind
            for p in folder.iterdir() if folder.is_dir() else ():
                if p.is_file() and not (p.suffix == ".part" and _mtime(p) > recent):
                    removed[1] += _size(p)
                    p.unlink(missing_ok=True)
                    removed[0] += 1
        return removed[0], removed[1]


def _size(p: Path) -> int:
    try:
        return p.stat().st_size
    except OSError:
        return 0


def _mtime(p: Path) -> float:
    try:
        return p.stat().st_mtime
    except OSError:
        return 0.0


def mesh_key(model: str, parameters: dict, contacts: tuple, code: str) -> str:
    """The key of a parametric model's mesh: the model, its parameters, the declared
    contacts, the code that meshes it (``code``: a digest) and the Gmsh version."""
    import gmsh

    text = json.dumps({"model": model, "parameters": parameters, "contacts": contacts,
                       "code": code, "gmsh": gmsh.__version__}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def kept_mesh(cache: SharedCache, key: str, build: Callable[[], object]
              ) -> tuple[object, Path | None]:
    """(mesh, its cache file if it came from there, else None): the mesh kept under
    ``key``, or ``build()`` kept there (a cache that cannot be written is skipped)."""
    from microslip.geometry.stored import load_mesh, save_mesh

    path = cache.meshes / f"mesh-{key}.h5"
    if path.is_file():
        try:
            mesh = load_mesh(path)
        except (OSError, KeyError, ValueError):  # damaged, or another format: built again
            pass
        else:
            cache.used([path])
            return mesh, path
    mesh = build()
    with contextlib.suppress(OSError):  # a cache that cannot take it: the run goes on
        save_mesh(mesh, path)
    return mesh, None


def built_mesh(table, cache: SharedCache | None) -> tuple[object, Path | None]:
    """(the mesh of a [geometry] table, its cache file if it came from there): a parametric
    model's Gmsh mesh is kept in ``cache`` (an imported file is read: it is its own store).
    ValueError for a declared contact the mesh cannot make (not kept)."""
    if table.imported or cache is None:
        return table.build(), None
    from .store import code_digest

    # the meshing code, and the declared contacts' (case.geometry_table.with_contacts)
    code = code_digest(parts=("microslip.geometry", "microslip.case.geometry_table"),
                       leave_out=())
    key = mesh_key(table.model, dict(table.parameters), table.contacts, code)
    return kept_mesh(cache, key, table.build)
