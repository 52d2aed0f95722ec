"""A :class:`Mesh` in an HDF5 file and back, exactly: the same arrays, names, cyclic faces,
contacts and parameters, so the same ``content_hash`` (what the reduced models are keyed
by). The shared cache keeps meshes this way (HDF5, never pickle: a cache is safe to open).

Every field of the mesh dataclasses is written by its type (arrays as datasets, mappings
of arrays or of dataclasses as groups, the rest as JSON), so a field added to them is kept
too, or refused by :func:`save_mesh` if its type is new (a test round-trips every model).
Names (node sets hold "/") are attributes, not HDF5 paths.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .boundaries import AveragedContact, ContactPatch, CyclicBoundary, Support, SurfaceContact
from .mesh import Mesh

FORMAT = 1
#: The dataclasses a mesh holds in its mappings, by the name written with each.
KINDS = {cls.__name__: cls for cls in (CyclicBoundary, ContactPatch, SurfaceContact,
                                       AveragedContact, Support)}
#: The attributes of a mapping's entry: its key and (a dataclass) its kind; a dataclass'
#: fields are attributes too, so these are names no field has.
KEY, KIND = "__key__", "__kind__"


def written_whole(path: str | Path, fill: Callable[[Any], None]) -> None:
    """Write the HDF5 file ``path`` whole or not at all: ``fill(file)`` builds it in
    memory, then its bytes go to a temporary name of this process and are renamed. HDF5
    meeting a full disk mid-file corrupts its own state (h5py then fails closing the file,
    or crashes); plain file writes fail cleanly (OSError, ENOSPC), and the temporary file
    is removed."""
    import io

    import h5py

    path = Path(path)
    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as f:
        fill(f)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.part")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as out:
            out.write(buffer.getbuffer())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def save_mesh(mesh: Mesh, path: str | Path) -> None:
    """Write ``mesh`` to ``path`` (HDF5, whole or not at all); TypeError for a field of a
    type it cannot keep."""

    def fill(f) -> None:
        f.attrs["format"] = FORMAT
        _put(f, mesh)

    written_whole(path, fill)


def load_mesh(path: str | Path) -> Mesh:
    """The mesh :func:`save_mesh` wrote (validated again as it is built); KeyError or
    ValueError for a file of another format."""
    import h5py

    with h5py.File(path, "r") as f:
        if int(f.attrs.get("format", -1)) != FORMAT:
            raise ValueError(f"{path}: mesh format {f.attrs.get('format')}, expected {FORMAT}")
        return _get(f, Mesh)


def _put(g, obj: Any) -> None:
    """The fields of dataclass ``obj`` into group ``g``."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            g.create_dataset(f.name, data=value)
        elif isinstance(value, dict) and all(isinstance(v, np.ndarray) for v in value.values()) \
                and f.name != "parameters":
            sub = g.create_group(f.name)
            for i, (name, arr) in enumerate(value.items()):
                sub.create_dataset(str(i), data=arr).attrs[KEY] = name
        elif isinstance(value, dict) and value and all(
                dataclasses.is_dataclass(v) for v in value.values()):
            sub = g.create_group(f.name)
            for i, (name, item) in enumerate(value.items()):
                entry = sub.create_group(str(i))
                entry.attrs[KEY] = name
                entry.attrs[KIND] = type(item).__name__
                if type(item).__name__ not in KINDS:
                    raise TypeError(f"Mesh.{f.name}[{name!r}]: cannot keep a "
                                    f"{type(item).__name__}")
                _put(entry, item)
        elif isinstance(value, dict) and not value:
            g.create_group(f.name)
        else:
            try:
                g.attrs[f.name] = json.dumps(value)
            except TypeError:
                raise TypeError(f"{type(obj).__name__}.{f.name}: cannot keep a "
                                f"{type(value).__name__}") from None


def _get(g, cls: type) -> Any:
    """An instance of dataclass ``cls`` from group ``g`` (written by :func:`_put`)."""
    import h5py

    values = {}
    for f in dataclasses.fields(cls):
        if f.name in g.attrs:
            values[f.name] = json.loads(g.attrs[f.name])
        elif f.name not in g:
            continue  # a field with a default, absent from an older file of this format
        elif isinstance(g[f.name], h5py.Dataset):
            values[f.name] = g[f.name][()]
        else:
            entries = sorted(g[f.name].values(), key=lambda e: int(e.name.rsplit("/", 1)[1]))
            values[f.name] = {
                str(e.attrs[KEY]): e[()] if isinstance(e, h5py.Dataset)
                else _get(e, KINDS[str(e.attrs[KIND])]) for e in entries}
    return cls(**values)
