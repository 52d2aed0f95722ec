"""The supports of Nastran and Ansys decks (what ``*BOUNDARY`` is to an Abaqus deck, read by
``geometry.abaqus``): the node ids each card holds and in which translations, in the
file's basic frame.

* Nastran: ``SPC1`` (SID, C, G1, G2, ... or G1 ``THRU`` G2) and ``SPC`` (SID, G, C, D
  pairs) in free, small and large field format; C is a string of components (``123456``):
  1-3 the translations held, 4-6 rotations, which solid grids do not have. A non-zero D, an
  ``SPCD`` (a prescribed motion, a load) or a held grid whose displacement frame (``GRID``
  CD) is not the basic one is refused: :class:`SupportError`.
* Ansys archives: ``D`` commands (``D,node,UX,0.0``; ``UX``, ``UY``, ``UZ``, ``ALL``); a
  non-zero value is refused, rotations are counted out.

Each returns (node ids, held translations (1-3), the card) per card.
"""

from __future__ import annotations

from pathlib import Path

from .materials import nastran_cards, nastran_real


class SupportError(ValueError):
    """A deck's support that cannot be read as one; one line naming the card and why."""


def _components(field: str, card: str) -> tuple[int, ...]:
    digits = sorted({int(c) for c in field.strip() if c.isdigit()})
    if not digits or any(d < 1 or d > 6 for d in digits):
        raise SupportError(f"{card}: component {field!r}: expected digits 1-6")
    return tuple(d for d in digits if d <= 3)


def nastran(path: str | Path) -> list[tuple[list[int], tuple[int, ...], str]]:
    """The SPC and SPC1 cards of a Nastran deck (see the module)."""
    out: list[tuple[list[int], tuple[int, ...], str]] = []
    frames: dict[int, str] = {}
    for name, f in nastran_cards(Path(path)):
        f = [v.strip() for v in f]
        if name == "GRID" and len(f) > 5:
            frames[int(f[0])] = f[5]
        elif name == "SPCD":
            raise SupportError(f"{path}: SPCD {' '.join(f[:4])}: a prescribed displacement "
                               "is a load, not a support; only supports are read")
        elif name == "SPC1":
            card = f"SPC1 {' '.join(x for x in f[:4] if x)}"
            held = _components(f[1], f"{path}: {card}")
            ids = [x for x in f[2:] if x]
            if len(ids) == 3 and ids[1].upper() == "THRU":
                grids = list(range(int(ids[0]), int(ids[2]) + 1))
            else:
                grids = [int(x) for x in ids]
            out.append((grids, held, card))
        elif name == "SPC":
            for j in range(1, len(f) - 1, 3):
                if not f[j]:
                    continue
                card = f"SPC {f[0]} {f[j]} {f[j + 1]}"
                if j + 2 < len(f) and f[j + 2] and nastran_real(f[j + 2]) != 0.0:
                    raise SupportError(f"{path}: {card} D = {f[j + 2]}: a non-zero "
                                       "displacement is a load, not a support; only supports "
                                       "are read")
                out.append(([int(f[j])], _components(f[j + 1], f"{path}: {card}"), card))
    for grids, held, card in out:
        local = [g for g in grids if frames.get(g, "") not in ("", "0")]
        if held and local:
            raise SupportError(f"{path}: {card}: grid {local[0]} has displacement frame CD = "
                               f"{frames[local[0]]}; supports in a grid's own frame are not "
                               "read (give them in the case's [reduction.bodies] supports)")
    return [x for x in out if x[1]]


_ANSYS = {"UX": (1,), "UY": (2,), "UZ": (3,), "ALL": (1, 2, 3)}


def ansys(path: str | Path) -> list[tuple[list[int], tuple[int, ...], str]]:
    """The D commands of an Ansys archive (see the module)."""
    out = []
    for number, line in enumerate(Path(path).read_text(errors="replace").splitlines(), 1):
        if not line.upper().startswith("D,"):
            continue
        f = [v.strip() for v in line.split(",")] + ["", ""]
        label = f[2].upper()
        if label not in _ANSYS and label not in ("ROTX", "ROTY", "ROTZ"):
            raise SupportError(f"{path}:{number}: D on {label}: only UX, UY, UZ, ALL (and "
                               "rotations, which solid nodes do not have) are read")
        if f[3] and nastran_real(f[3]) != 0.0:
            raise SupportError(f"{path}:{number}: D {f[1]} {label} = {f[3]}: a non-zero "
                               "displacement is a load, not a support; only supports are read")
        if label in _ANSYS:
            out.append(([int(float(f[1]))], _ANSYS[label], f"{path}:{number}"))
    return out
