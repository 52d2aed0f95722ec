"""Isotropic elastic materials from the cards of Nastran and Ansys decks (``material =
"file"``), in the file's units. The Abaqus/CalculiX deck reader reads its own
(``geometry.abaqus``); meshio and ansys-mapdl-reader read no material at all.

* Nastran: ``MAT1`` (MID, E, G, NU, RHO; a blank E, G or NU follows from the other two, as
  Nastran does) and ``PSOLID`` (PID, MID), in free (commas), small (8 columns) and large
  (``MAT1*``, 16 columns) field format; reals in Nastran's forms (``7.85-9``, ``2.1+5``).
* Ansys archives: ``MPDATA`` of EX, PRXY (or NUXY) and DENS per material number, as
  CDWRITE writes them (``MPDATA,R5.0, 1,EX  ,  1, 1,  2.1E+11,``), as Workbench writes them
  (``MPDATA,UNBL,16,EX,1,1,2.1E+11``) or as typed (``MPDATA,EX,1,,2.1E11``): the label is
  the first field that names a property, then material, location and value.

Each returns material key -> (E, nu, rho) (nan where the deck gives none).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

_NASTRAN_REAL = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)$")  # 7.85-9 = 7.85e-9


def nastran_real(field: str) -> float:
    """A Nastran or Ansys real ("" -> nan)."""
    field = field.strip().replace("D", "E").replace("d", "e")
    if not field:
        return math.nan
    match = _NASTRAN_REAL.match(field)
    return float(f"{match.group(1)}e{match.group(2)}" if match else field)


def nastran_cards(path: Path):
    """(name, fields) of every bulk-data card, continuations joined."""
    card: list[str] = []
    for raw in Path(path).read_text(errors="replace").splitlines():
        line = raw.split("$", 1)[0].rstrip()
        if not line.strip():
            continue
        if "," in line:
            fields = [f.strip() for f in line.split(",")]
        elif line[:8].rstrip().endswith("*") or line.startswith("*"):
            fields = [line[:8].strip()] + [line[8 + 16 * i: 24 + 16 * i].strip()
                                           for i in range(4)]
        else:
            fields = [line[8 * i: 8 * i + 8].strip() for i in range(9)]
        head = fields[0]
        if head.startswith(("+", "*")) or (head == "" and card):  # a continuation
            card += fields[1:]
            continue
        if card:
            yield card[0].rstrip("*").upper(), card[1:]
        card = fields
    if card:
        yield card[0].rstrip("*").upper(), card[1:]


def nastran(path: str | Path) -> dict[int, tuple[float, float, float]]:
    """Property id -> (E, nu, rho) of its PSOLID's MAT1."""
    mat1: dict[int, tuple[float, float, float]] = {}
    psolid: dict[int, int] = {}
    for name, f in nastran_cards(Path(path)):
        f = f + [""] * 8
        if name == "MAT1":
            E, G, nu, rho = (nastran_real(v) for v in f[1:5])
            if math.isnan(nu) and not (math.isnan(E) or math.isnan(G)):
                nu = E / (2.0 * G) - 1.0
            if math.isnan(E) and not (math.isnan(G) or math.isnan(nu)):
                E = 2.0 * G * (1.0 + nu)
            mat1[int(f[0])] = (E, nu, rho)
        elif name == "PSOLID":
            psolid[int(f[0])] = int(f[1])
    return {pid: mat1[mid] for pid, mid in psolid.items() if mid in mat1}


#: MPDATA property labels (the elastic and density ones, and those beside them in a deck)
_ANSYS_LABELS = {"EX", "EY", "EZ", "PRXY", "PRYZ", "PRXZ", "NUXY", "NUYZ", "NUXZ", "GXY",
                 "GYZ", "GXZ", "DENS", "ALPX", "ALPY", "ALPZ", "KXX", "KYY", "KZZ", "C", "MU",
                 "DAMP", "REFT", "CTEX", "CTEY", "CTEZ", "THSX", "THSY", "THSZ", "ENTH"}


def ansys(path: str | Path) -> dict[int, tuple[float, float, float]]:
    """Material number -> (E, nu, rho) from MPDATA cards."""
    found: dict[int, dict[str, float]] = {}
    for line in Path(path).read_text(errors="replace").splitlines():
        if not line.upper().startswith("MPDATA"):
            continue
        f = [v.strip() for v in line.split(",")] + [""] * 4
        at = next((i for i, v in enumerate(f[1:4], 1) if v.upper() in _ANSYS_LABELS), None)
        if at is None:
            continue
        label, mat, value = f[at].upper(), f[at + 1], f[at + 3]
        if label in ("EX", "PRXY", "NUXY", "DENS") and mat:
            found.setdefault(int(mat), {}).setdefault(label, nastran_real(value))
    out = {}
    for mat, props in found.items():
        nu = props.get("PRXY", props.get("NUXY", math.nan))
        out[mat] = (props.get("EX", math.nan), nu, props.get("DENS", math.nan))
    return out
