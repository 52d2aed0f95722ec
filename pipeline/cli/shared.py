"""What several commands share: exit codes, the case loaded or refused in one line, the
output folder checked before any work, the shared cache."""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

INTERRUPTED = 130  # Ctrl-C (128 + SIGINT), for every command


MAX_THREADS = 256  # --threads at most (a sanity bound: no machine here has more cores)


TERMINATED = 143  # SIGTERM during `run` (128 + SIGTERM, what a shell reports for a kill)


BROKEN_PIPE = 141  # stdout closed early, e.g. `| head` (128 + SIGPIPE, as for other tools)


def load_case(command: str, path):
    """The validated case, or None after printing its faults (one line when one fault)."""
    from microslip.case import CaseError, load

    try:
        case = load(path)
    except CaseError as err:
        print(f"microslip {command}: {err}", file=sys.stderr)
        return None
    for note in case.renamed:  # the user has something to do: rename the table
        print(f"{path}: note: {note}")
    return case


def output_folder(command: str, out: Path, given: bool) -> bool:
    """Whether ``out`` is a folder we can write (created if missing), checked before any
    heavy work; else prints one line saying why and returns False."""
    what = f"--out {out}" if given else f"output folder {out}"
    if out.exists() and not out.is_dir():
        problem = "exists and is not a folder"
    else:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            problem = f"cannot create the folder ({err.strerror})"
        else:
            try:  # a real write (a nameless file): permissions and read-only mounts show here
                with tempfile.TemporaryFile(dir=out):
                    return True
            except OSError as err:
                problem = f"cannot write in the folder ({err.strerror})"
    print(f"microslip {command}: {what}: {problem}; give a writable folder", file=sys.stderr)
    return False


def shared_cache(command: str):
    """The shared cache of meshes and reduced models (``app.cache``), or None after one
    line saying why it cannot be used (a bad setting, a folder that cannot be written)."""
    from microslip.app.cache import CacheSettingError, SharedCache

    try:
        shared = SharedCache.from_environment()
    except CacheSettingError as err:
        print(f"microslip {command}: {err}", file=sys.stderr)
        return None
    fault = shared.check_writable()
    if fault:
        print(f"microslip {command}: the shared cache of meshes and reduced models: {fault}; "
              "set MICROSLIP_CACHE to a writable folder", file=sys.stderr)
        return None
    return shared
