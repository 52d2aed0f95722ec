"""Pictures written whole or not at all."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

#: A complete PNG ends with its IEND chunk (length 0, type, CRC).
PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"


@contextlib.contextmanager
def written(path: str | Path) -> Iterator[Path]:
    """A temporary path (same folder and suffix) to draw into; it becomes ``path`` when the
    block ends with a complete file, and is removed otherwise: a full disk leaves neither a
    truncated picture nor a stray temporary file. (VTK reports a failed write on its own
    console without raising, so a PNG is checked for its end.)"""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    try:
        yield tmp
        if path.suffix.lower() == ".png" and not _complete_png(tmp):
            full = shutil.disk_usage(tmp.parent).free < 1 << 20
            raise OSError(errno.ENOSPC if full else errno.EIO,
                          f"{path.name}: the picture was not written completely")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _complete_png(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            f.seek(-len(PNG_END), os.SEEK_END)
            return f.read() == PNG_END
    except OSError:
        return False
