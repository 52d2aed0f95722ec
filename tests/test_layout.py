"""The shape of the house: one import name, stages that import one way, no circles.

Reads the source files (imports inside functions count too); nothing is imported.
"""

import ast
import importlib.metadata
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOPS = {"geometry": "microslip.geometry", "pipeline": "microslip"}

# Each stage and the stages below it that it may import (besides its own modules). Read top
# down, this is the data flow: cli -> bench -> app -> case -> assembly -> solve -> laws,
# fe -> geometry; app reads cases (case), writes results (results) and draws them (draw);
# report makes a results file's page from its pictures (draw) and numbers (results);
# draw reads only results, the analysis specs that name what they hold, and the numerical
# stages' constants (states, harmonics, frames), never app.
_GEO, _FE, _LAWS = "microslip.geometry", "microslip.fe", "microslip.laws"
_FOURIER = "microslip.fourier"  # the harmonic-balance layout: the floor of the numerics
_SOLVE, _ASSEMBLY = "microslip.solve", "microslip.assembly"
_RESULTS, _DRAW, _REPORT = "microslip.results", "microslip.draw", "microslip.report"
_CASE, _APP = "microslip.case", "microslip.app"
_BENCH = "microslip.bench"
_NUMERICS = {_ASSEMBLY, _SOLVE, _LAWS, _FOURIER, _FE, _GEO}
BELOW = {
    _GEO: set(),
    _FE: {_GEO},
    _FOURIER: set(),
    _LAWS: {_FOURIER},
    _SOLVE: {_LAWS, _FOURIER, _FE, _GEO},
    _ASSEMBLY: {_SOLVE, _LAWS, _FOURIER, _FE, _GEO},
    _CASE: _NUMERICS,
    _RESULTS: set(),
    _DRAW: {_RESULTS, _CASE, _LAWS, _FOURIER, _FE, _GEO},
    # the page of a results file: its pictures (draw) and numbers (results), as draw reads
    _REPORT: {_DRAW, _RESULTS, _CASE, _LAWS, _FOURIER, _FE, _GEO},
    _APP: {_CASE, _DRAW, _RESULTS} | _NUMERICS,
    _BENCH: {_APP, _CASE, _DRAW, _RESULTS} | _NUMERICS,
    "microslip.cli": {_BENCH, _APP, _CASE, _DRAW, _REPORT, _RESULTS} | _NUMERICS,
    # the package's __init__: the public API (``from microslip import ...``), over every stage
    "microslip": {_BENCH, _APP, _CASE, _DRAW, _RESULTS} | _NUMERICS,
}


def _modules() -> dict[str, Path]:
    """Installed name -> source file of every module of the two folders."""
    mods = {}
    for top, name in TOPS.items():
        for path in (ROOT / top).rglob("*.py"):
            parts = list(path.relative_to(ROOT / top).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join([name, *parts])] = path
    return mods


MODULES = _modules()


def _stage(module: str) -> str:
    return max((s for s in BELOW if module == s or module.startswith(s + ".")), key=len)


def _imports(module: str, path: Path) -> list[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) for every import of a module."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            for a in node.names:
                sub = f"{base}.{a.name}"
                found.append((sub, None, node.lineno) if sub in MODULES
                             else (base, a.name, node.lineno))
    return found


def _project_imports():
    for module, path in sorted(MODULES.items()):
        for target, name, line in _imports(module, path):
            yield module, f"{path.relative_to(ROOT)}:{line}", target, name


def test_every_module_has_a_stage():
    assert len(MODULES) > 30
    assert {_stage(m) for m in MODULES} >= {_GEO, _FE, _LAWS, _SOLVE, _APP, _BENCH}


def test_imports_use_the_microslip_name():
    """`import pipeline` / `import geometry` would load a second copy (or another package)."""
    bad = [f"{where}: {target}" for _, where, target, _ in _project_imports()
           if target.split(".")[0] in TOPS]
    assert not bad


def test_no_lower_stage_imports_a_higher_one():
    bad = []
    for module, where, target, _ in _project_imports():
        if not target.startswith("microslip.") or target not in MODULES and not any(
                m.startswith(target + ".") for m in MODULES):
            continue  # a third-party import
        mine, theirs = _stage(module), _stage(target)
        if theirs != mine and theirs not in BELOW[mine]:
            bad.append(f"{where}: {mine} imports {target} ({theirs})")
    assert not bad


def test_no_module_imports_another_modules_private_names():
    bad = [f"{where}: {name} from {target}" for module, where, target, name in
           _project_imports() if name and name.startswith("_") and target != module
           and target in MODULES]
    assert not bad


def test_no_import_circle():
    graph = {m: set() for m in MODULES}
    for module, _, target, _ in _project_imports():
        if target in MODULES and target != module and MODULES[target].name != "__init__.py":
            graph[module].add(target)
    circles = []

    def visit(m, trail):
        for t in graph[m]:
            if t in trail:
                circles.append(" -> ".join(trail[trail.index(t):] + [t]))
            elif t not in done:
                visit(t, trail + [t])
        done.add(m)

    done: set[str] = set()
    for m in sorted(graph):
        if m not in done:
            visit(m, [m])
    assert not circles


def test_the_distribution_installs_only_the_microslip_name(tmp_path):
    dist = importlib.metadata.distribution("microslip")
    assert (dist.read_text("top_level.txt") or "").split() == ["microslip"]
    # Outside the checkout (whose folders Python would find in the working directory), only
    # `microslip` imports: the folders' own names are not installed.
    code = ("import importlib.util as u, microslip.cli, microslip.geometry; "
            "print(u.find_spec('pipeline'), u.find_spec('geometry'))")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == ["None", "None"]


def test_every_package_folder_is_installed():
    """`pip install .` (the README's main job) installs the packages pyproject lists, and
    only those: every folder with an __init__.py must be there (case/, draw/, results/ and
    two sub-packages were not, and the installed command could not import them)."""
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    folders = {".".join([TOPS[top], *p.parent.relative_to(ROOT / top).parts])
               for top in TOPS for p in (ROOT / top).rglob("__init__.py")}
    assert listed == folders


@pytest.mark.slow
def test_the_wheel_holds_only_microslip(tmp_path):
    """`pip install .` installs the wheel built here: every file under microslip/ (and the
    distribution's metadata): pipeline/ mapped to microslip/, geometry/ to microslip/geometry/."""
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path),
                    str(ROOT)], check=True, capture_output=True)
    (wheel,) = tmp_path.glob("microslip-*.whl")
    tops = {n.split("/")[0] for n in zipfile.ZipFile(wheel).namelist()}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"microslip"}
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "microslip/solve/hbm.py" in names
    assert "microslip/geometry/blisk.py" in names
