"""microslip: friction contacts in bladed-disk dynamics, from a meshed geometry to the
forced response.

The public API is this module's ``__all__`` (``from microslip import HarmonicBalance``):
the lumped harmonic balance and its continuation, and the case files' run, check and
render. Names load on first use, so ``import microslip.fe.fem`` stays light.

The sub-packages read as the data flow; imports run one way, from the top down
(``tests/test_layout.py`` holds it, ``tests/test_packages.py`` this map):

    cli        the ``microslip`` command
    bench      benchmarks and small demos
    app        a run: the analyses, the structural stage, the curve cache, tasks, limits
    case       case files: read, validated, their specs, estimates and models
    draw       pictures of a results file (FRFs, maps, previews, shapes)
    report     the page of a results folder (report.html) and an index over several
    results    results.h5: its layout, writer and comparison
    assembly   reduced bodies joined by contact patches
    solve      harmonic balance, continuation, response curves, stability, time integration
    laws       contact laws: friction A-D (the compiled return map), benchmark springs
    fourier    the harmonic-balance layout: orders, coefficients, samples, DFT
    fe         K, M, cyclic matrices, reductions, contact-patch stiffness, sparse solvers
    geometry   Gmsh models, imported meshes, contact pairing (the folder geometry/)

``fe`` and ``laws`` are independent of each other; ``fe`` reads meshes from
:mod:`microslip.geometry`, the bottom of the house.
"""

from __future__ import annotations

import importlib
from typing import Any

#: public name -> the module that defines it
_HOMES = {
    "Harmonics": "microslip.fourier",
    "ContactElements": "microslip.laws.coulomb",
    "Contact": "microslip.solve.hbm",
    "Excitation": "microslip.solve.linear",
    "HarmonicBalance": "microslip.solve.hbm",
    "LinearDynamics": "microslip.solve.linear",
    "OperatingPoint": "microslip.solve.linear",
    "Response": "microslip.solve.response",
    "sweep": "microslip.solve.response",
    "peak_curve": "microslip.solve.peaks",
    "hill_stability": "microslip.solve.stability",
    "Case": "microslip.case",
    "load": "microslip.case",
    "check": "microslip.case",
    "run_case": "microslip.app.run",
    "render": "microslip.draw.pictures",
    "differences": "microslip.results.compare",
}

__all__ = sorted(_HOMES)


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (PEP 562)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'microslip' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), name)
    globals()[name] = value  # the next use finds it directly
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
