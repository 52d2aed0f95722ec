"""Case files (TOML): read, validate, and the validated case.

A lumped case names its DOFs and writes M, K, C directly; contacts give their law, form,
parameters and the relative displacements as linear combinations of named DOFs (the
reference text's eqs. 21-23); loads are amplitude and phase per DOF and harmonic (order 0:
static). A meshed case gives [geometry], [reduction] and [assembly] instead. Analyses
(``[[analysis]]``) say what to compute; their keys and defaults are :mod:`.specs`'.

Every fault found is reported, one line each, naming the key, the value and what is
allowed, before anything is computed (:class:`CaseError`). The key reference with units
and defaults is in the README.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from .estimate import memory_faults
from .faults import faults
from .kinds import Kinds
from .validated import Case, CaseError


def load(path: str | Path, kinds: Kinds | None = None) -> Case:
    """Read and validate a case file (its analyses of the types ``kinds``, default the
    shipped ones); raises CaseError listing every fault."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except OSError as err:
        raise CaseError(str(path), [f"cannot read the file: {err.strerror}"
                                    + numbered_name(path)]) from None
    except UnicodeDecodeError as err:  # tomllib decodes first: a binary file lands here
        raise CaseError(str(path), [
            f"not a text file: byte 0x{err.object[err.start]:02x} at offset {err.start} is "
            "not UTF-8; a case file is TOML text (UTF-8)"]) from None
    except tomllib.TOMLDecodeError as err:
        raise CaseError(str(path), [f"not valid TOML: {err}"]) from None
    data, renamed = renamed_tables(data, str(path))
    data = with_mesh_path(data, path.parent)
    check(data, str(path), kinds=kinds)
    return Case(data, str(path), renamed, kinds)


def numbered_name(path: Path) -> str:
    """Where a shipped case named without its number, or with an earlier one, is now (the
    cases are numbered in their learning order: ``sdof_wall.toml`` is ``01_sdof_wall.toml``,
    ``10_blisk_quick.toml`` became ``11_blisk_quick.toml``), or ""."""
    if path.exists():
        return ""
    name = re.sub(r"^[0-9][0-9]_", "", path.name)
    found = sorted(path.parent.glob(f"[0-9][0-9]_{name}"))
    return f"; the shipped cases are numbered now: {found[0]}" if found else ""


def with_mesh_path(data: dict, base: Path) -> dict:
    """The case with an imported mesh's ``geometry.file`` made absolute (it is relative to
    the case file): the case as run names the file it read, wherever it runs from."""
    geo = data.get("geometry")
    if not (isinstance(geo, dict) and geo.get("model") == "import"
            and isinstance(geo.get("file"), str) and geo["file"]):
        return data
    return {**data, "geometry": {**geo, "file": str((base / geo["file"]).resolve())}}


#: Tables renamed since a release, old name -> new: a file with the old name is read as the
#: new one, and ``check`` and ``run`` say so (a note: rename the table).
RENAMED = {"coupling": "assembly"}  # joined bodies are an assembly: "coupled" is a contact form


def renamed_tables(data: dict, source: str) -> tuple[dict, tuple[str, ...]]:
    """(the case table with every old table name read as its new one, a note per rename);
    a file giving both names is refused."""
    notes = []
    for old, new in RENAMED.items():
        if old not in data:
            continue
        if new in data:
            raise CaseError(source, [f"[{old}] and [{new}]: [{old}] is the old name of "
                                     f"[{new}]; give [{new}] only"])
        data = {(new if k == old else k): v for k, v in data.items()}
        data["analysis"] = [_renamed_paths(a, old, new) for a in data.get("analysis", [])]
        notes.append(f"[{old}] is now called [{new}] (read as [{new}]); rename the table "
                     f"and its [[{old}.*]] arrays")
    return data, tuple(notes)


def _renamed_paths(analysis, old: str, new: str):
    """An [[analysis]] table with its dotted key paths (``set``, ``family``) under the old
    table name moved to the new one."""
    if not isinstance(analysis, dict):
        return analysis

    def path(key):
        return new + key[len(old):] if isinstance(key, str) and key.startswith(old + ".") \
            else key

    def table(t):
        return {path(k): v for k, v in t.items()} if isinstance(t, dict) else t

    out = dict(analysis)
    if "set" in out:
        out["set"] = table(out["set"])
    family = out.get("family")
    if isinstance(family, dict):
        family = dict(family)
        if "key" in family:
            family["key"] = path(family["key"])
        if isinstance(family.get("sets"), list):
            family["sets"] = [table(t) for t in family["sets"]]
        out["family"] = family
    return out


def check(data: dict, source: str = "case", *, memory: bool = True,
          kinds: Kinds | None = None) -> None:
    """Validate a case table (its analyses of the types ``kinds``, default the shipped
    ones); raises CaseError with one line per fault. With ``memory``, a valid case whose
    largest analysis needs more than the machine's available memory (:func:`sizes`) is
    refused too, before anything is built."""
    found: list[str] = []
    faults(data, found, kinds=kinds)
    if not found and memory:
        memory_faults(data, found, kinds)
    if found:
        raise CaseError(source, found)
