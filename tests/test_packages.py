"""The package maps and the public API tell the truth.

Every package's ``__init__`` docstring opens with a map of its folder (a line per module or
sub-package: its name, two spaces or more, what it holds); the map names exactly what the
folder holds. ``from microslip import ...`` gives the names of ``__all__``, each the object of
the module that defines it, and ``import microslip`` alone imports none of them.
"""

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

import microslip

ROOT = Path(__file__).resolve().parents[1]
ENTRY = re.compile(r"^( *)([a-z_][a-z0-9_]*) {2,}\S")


def _packages() -> list[Path]:
    return sorted(p.parent for top in ("pipeline", "geometry")
                  for p in (ROOT / top).rglob("__init__.py"))


def map_names(doc: str) -> set[str]:
    """The names of the first run of map lines in a docstring (continuation lines are
    indented deeper than the entries; a blank or other line ends the map)."""
    names: list[str] = []
    indent = None
    for line in doc.splitlines():
        m = ENTRY.match(line)
        if m and (indent is None or len(m.group(1)) == indent):
            indent = len(m.group(1))
            names.append(m.group(2))
        elif names and line.strip() and len(line) - len(line.lstrip()) > indent:
            continue  # a continuation of the entry above
        elif names:
            break
    return set(names)


def held(folder: Path) -> set[str]:
    """The public modules and sub-packages of a package folder (the root also maps the
    geometry/ folder, installed as microslip.geometry)."""
    out = {p.stem for p in folder.glob("*.py") if not p.name.startswith("_")}
    out |= {p.name for p in folder.iterdir() if (p / "__init__.py").is_file()}
    return out | ({"geometry"} if folder == ROOT / "pipeline" else set())


@pytest.mark.parametrize("folder", _packages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_package_map_names_what_its_folder_holds(folder):
    doc = ast.get_docstring(ast.parse((folder / "__init__.py").read_text())) or ""
    named = map_names(doc)
    assert named == held(folder), (f"{folder.relative_to(ROOT)}: the map lacks "
                                   f"{sorted(held(folder) - named)}, names absent "
                                   f"{sorted(named - held(folder))}")


def test_the_map_reader_reads_entries_and_continuations_and_stops():
    doc = "Title.\n\nfirst   one\n        more of it\nsecond  two\n\n    prose   later\n"
    assert map_names(doc) == {"first", "second"}


def test_the_public_names_are_their_modules_objects():
    import importlib

    for name in microslip.__all__:
        home = importlib.import_module(microslip._HOMES[name])
        assert getattr(microslip, name) is getattr(home, name)
    assert set(dir(microslip)) >= set(microslip.__all__)
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        microslip.nothing  # noqa: B018


def test_import_microslip_alone_stays_light():
    """The API loads on first use: a worker importing microslip.fe.fem does not pay for the
    solver, the drawing or the command."""
    code = ("import sys, microslip; print(sorted(m for m in sys.modules "
            "if m.startswith('microslip.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"
