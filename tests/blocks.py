"""Two blocks meshed independently, one standing on the other: the contact tests' meshes."""

import numpy as np

from microslip.geometry import Mesh
from microslip.geometry.structured import grid, split_cells


def two_blocks(lower: tuple[str, tuple[int, int, int]], upper: tuple[str, tuple[int, int, int]],
               lower_size=(0.1, 0.05, 0.02), upper_size=(0.06, 0.03, 0.01),
               offset=(0.02, 0.01)) -> Mesh:
    """Bodies "lower" (a box at the origin) and "upper" (a box on its top face, its corner at
    ``offset``), each (shape, cells) meshed on its own grid (``split_cells`` shapes). Node
    sets: "lower/top", "lower/clamp" (its bottom), "upper/bottom", "upper/top",
    "upper/excitation" and "upper/response" (its top)."""
    P1, h1 = grid(lower_size, lower[1])
    P2, h2 = grid(upper_size, upper[1])
    P2 = P2 + np.array([offset[0], offset[1], lower_size[2]])
    t1, x1, w1 = split_cells(lower[0], h1)
    t2, x2, w2 = split_cells(upper[0], h2 + len(P1))
    cells = [np.vstack([a, b]) for a, b in ((t1, t2), (x1, x2), (w1, w2))]
    counts = [len(c) for c in cells]
    own = []
    for mine, before in (((t1, x1, w1), (0, 0, 0)), ((t2, x2, w2), (len(t1), len(x1), len(w1)))):
        starts = (0, counts[0], counts[0] + counts[1])
        own.append(np.concatenate([s + b + np.arange(len(m))
                                   for m, s, b in zip(mine, starts, before, strict=True)]))
    points = np.vstack([P1, P2])
    z_top = lower_size[2] + upper_size[2]

    def at(z, start, count):
        return start + np.flatnonzero(np.abs(points[start:start + count, 2] - z) < 1e-12)

    top = at(z_top, len(P1), len(P2))
    sets = {"lower/top": at(lower_size[2], 0, len(P1)), "lower/clamp": at(0.0, 0, len(P1)),
            "upper/bottom": at(lower_size[2], len(P1), len(P2)), "upper/top": top,
            "upper/excitation": top, "upper/response": top}
    return Mesh("blocks", points, cells[0], {"lower": own[0], "upper": own[1]}, sets,
                hexahedra=cells[1], wedges=cells[2])


def upper_block(shape: str, cells: tuple[int, int, int], size=(0.04, 0.04, 0.02),
                base: float = 0.02) -> Mesh:
    """The upper block of :func:`two_blocks` alone (body "upper", its bottom at z = base):
    node sets "upper/bottom", "upper/top", "upper/excitation", "upper/response"."""
    P, hexes = grid(size, cells)
    P = P + np.array([0.0, 0.0, base])
    tets, hexes, wedges = split_cells(shape, hexes)
    n = len(tets) + len(hexes) + len(wedges)
    top = np.flatnonzero(np.abs(P[:, 2] - base - size[2]) < 1e-12)
    sets = {"upper/bottom": np.flatnonzero(np.abs(P[:, 2] - base) < 1e-12), "upper/top": top,
            "upper/excitation": top, "upper/response": top}
    return Mesh("block", P, tets, {"upper": np.arange(n)}, sets, hexahedra=hexes,
                wedges=wedges)
