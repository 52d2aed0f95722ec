"""Contact stiffness of a patch (Firrone & Zucca 5.2) and local contact frames.

Flat punch on a half-space for the whole patch of area A (Johnson, *Contact Mechanics*, 1985;
tangential after Mindlin 1949), equivalent radius a = sqrt(A / pi):

    kn = 2 a E*,   1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2
    kt = 8 a G*,   1/G* = (2 - nu1)/G1 + (2 - nu2)/G2,   G = E / (2 (1 + nu))

spread evenly over the patch's node pairs (the per-node values sum to the patch total).
A per-area stiffness [N/m^3] given by a case overrides it: k_node = k_area A / n_pairs.

Frame per node pair: rows (t1, t2, n), right-handed, n = the patch normal (outward from body
a into body b). The relative displacement of a pair is ``frames @ (u_a - u_b)``: its normal
component is positive when the bodies approach (the README's conventions).

Surfaces paired node by node (``geometry.pairing``) carry a tributary area and a normal per
pair: the contact's flat-punch stiffness is shared in proportion to the areas
(:func:`pairing_stiffness`; against the rigid ground, body b's compliance terms vanish), and
each pair's frame follows its own normal (``geometry.pairing.normal_frames``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .fem import Material


def equivalent_radius(area: float) -> float:
    """a = sqrt(A / pi) [m] of a patch of area A [m^2]."""
    if not (math.isfinite(area) and area > 0.0):
        raise ValueError(f"area={area!r}: must be a finite positive area [m^2]")
    return math.sqrt(area / math.pi)


def effective_modulus(a: Material, b: Material | None) -> float:
    """E* [Pa] with 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (b None: rigid, no term)."""
    rigid = b is None
    return 1.0 / (
        (1.0 - a.poisson_ratio**2) / a.youngs_modulus
        + (0.0 if rigid else (1.0 - b.poisson_ratio**2) / b.youngs_modulus)
    )


def effective_shear_modulus(a: Material, b: Material | None) -> float:
    """G* [Pa] with 1/G* = (2 - nu1)/G1 + (2 - nu2)/G2 (b None: rigid, no term)."""
    rigid = b is None
    return 1.0 / (
        (2.0 - a.poisson_ratio) / a.shear_modulus
        + (0.0 if rigid else (2.0 - b.poisson_ratio) / b.shear_modulus)
    )


def flat_punch_stiffness(area: float, a: Material, b: Material | None
                         ) -> tuple[float, float]:
    """(kn, kt) [N/m] of a whole patch of area [m^2] between materials a and b (b None:
    the rigid ground)."""
    radius = equivalent_radius(area)
    return 2.0 * radius * effective_modulus(a, b), 8.0 * radius * effective_shear_modulus(a, b)


@dataclass(frozen=True)
class PatchStiffness:
    """Normal and tangential stiffness per node pair of one patch.

    normal, tangential: (n1, n2) [N/m], in the patch's grid layout; totals: their sums.
    """

    patch: str
    normal: NDArray[np.float64]
    tangential: NDArray[np.float64]

    @property
    def total_normal(self) -> float:
        return float(self.normal.sum())

    @property
    def total_tangential(self) -> float:
        return float(self.tangential.sum())


def patch_stiffness(
    patch: Any,
    material_a: Material,
    material_b: Material,
    per_area: tuple[float, float] | None = None,
) -> PatchStiffness:
    """Per-node-pair (kn, kt) of a ContactPatch, evenly spread.

    per_area: (kn, kt) per unit area [N/m^3] overriding the flat-punch values.
    """
    shape = np.asarray(patch.nodes_a).shape
    n_pairs = int(np.prod(shape))
    if n_pairs == 0:
        raise ValueError(f"patch {patch.name!r} has no node pairs")
    if per_area is None:
        kn, kt = flat_punch_stiffness(patch.area, material_a, material_b)
    else:
        kn_a, kt_a = (float(v) for v in per_area)
        for name, v in (("per_area[0] (normal)", kn_a), ("per_area[1] (tangential)", kt_a)):
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"{name}={v!r}: must be a finite positive stiffness [N/m^3]")
        equivalent_radius(patch.area)  # validates the area
        kn, kt = kn_a * patch.area, kt_a * patch.area
    return PatchStiffness(
        patch=str(patch.name),
        normal=np.full(shape, kn / n_pairs),
        tangential=np.full(shape, kt / n_pairs),
    )


def contact_frames(patch: Any, points: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n1, n2, 3, 3) frame per node pair: rows t1, t2, n (right-handed, orthonormal).

    n is the patch normal; t1 follows the grid's first direction (nodes_a[i, j] ->
    nodes_a[i + 1, j]) projected onto the contact plane; t2 = n x t1.
    points: (n_nodes, 3) mesh coordinates [m].
    """
    n = np.asarray(patch.normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    grid = np.asarray(points)[np.asarray(patch.nodes_a)]  # (n1, n2, 3)
    if grid.shape[0] < 2:
        raise ValueError(f"patch {patch.name!r}: grid needs >= 2 nodes along its first axis")
    d = (grid[-1] - grid[0]).mean(axis=0)
    t1 = d - (d @ n) * n
    if np.linalg.norm(t1) < 1e-12 * max(np.linalg.norm(d), 1e-300):
        raise ValueError(f"patch {patch.name!r}: grid's first direction is along the normal")
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    frame = np.stack([t1, t2, n])
    return np.broadcast_to(frame, (*grid.shape[:2], 3, 3)).copy()


def initial_gaps(patch: Any, points_a: NDArray, points_b: NDArray) -> NDArray[np.float64]:
    """(n1, n2) normal gap [m] between paired nodes (positive = open), from their coordinates.

    points_a, points_b: (n1, n2, 3) assembled coordinates of the two sides (e.g.
    ``Mesh.patch_points(name, "a")``, which applies a neighbouring-sector rotation).
    """
    n = np.asarray(patch.normal, dtype=np.float64)
    return (np.asarray(points_b) - np.asarray(points_a)) @ n


def pairing_stiffness(name: str, areas: NDArray[np.float64], material_a: Material,
                      material_b: Material | None, per_area: tuple[float, float] | None = None
                      ) -> PatchStiffness:
    """Per-pair (kn, kt) [N/m] of surfaces paired node by node: the flat punch of the whole
    contact area (the sum of the tributary ``areas`` (k,) [m^2]), shared in proportion to
    each pair's area; ``per_area`` (kn, kt) [N/m^3] instead of the flat punch; material_b
    None: the rigid ground. The pairs of a uniform grid get equal shares, as
    :func:`patch_stiffness` gives them."""
    areas = np.asarray(areas, dtype=np.float64)
    if areas.ndim != 1 or not len(areas) or not np.all(areas > 0):
        raise ValueError(f"contact {name!r}: tributary areas must be positive, one per pair")
    total = float(areas.sum())
    if per_area is None:
        kn, kt = flat_punch_stiffness(total, material_a, material_b)
    else:
        kn, kt = (float(v) * total for v in per_area)
    share = areas / total
    return PatchStiffness(patch=name, normal=kn * share, tangential=kt * share)

