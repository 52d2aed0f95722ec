"""Case files (TOML): read, validate, and the validated case.

A lumped case names its DOFs and writes M, K, C directly; contacts give their law, form,
parameters and the relative displacements as linear combinations of named DOFs (the
reference text's eqs. 21-23); loads are amplitude and phase per DOF and harmonic (order 0:
static). A meshed case gives [geometry], [reduction] and [coupling] instead. Analyses
(``[[analysis]]``) say what to compute; their keys and defaults are :mod:`.specs`'.

Every fault found is reported, one line each, naming the key, the value and what is
allowed, before anything is computed (:class:`CaseError`). The key reference with units
and defaults is in the README.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from .estimate import memory_faults
from .validate import faults
from .validated import Case, CaseError


def load(path: str | Path) -> Case:
    """Read and validate a case file; raises CaseError listing every fault."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as err:
        raise CaseError(str(path), [f"cannot read the file: {err.strerror}"]) from None
    except UnicodeDecodeError as err:  # tomllib decodes first: a binary file lands here
        raise CaseError(str(path), [
            f"not a text file: byte 0x{err.object[err.start]:02x} at offset {err.start} is "
            "not UTF-8; a case file is TOML text (UTF-8)"]) from None
    except tomllib.TOMLDecodeError as err:
        raise CaseError(str(path), [f"not valid TOML: {err}"]) from None
    check(data, str(path))
    return Case(data, str(path))


def check(data: dict, source: str = "case", *, memory: bool = True) -> None:
    """Validate a case table; raises CaseError with one line per fault. With ``memory``, a
    valid case whose largest analysis needs more than the machine's available memory
    (:func:`sizes`) is refused too, before anything is built."""
    found: list[str] = []
    faults(data, found)
    if not found and memory:
        memory_faults(data, found)
    if found:
        raise CaseError(source, found)
