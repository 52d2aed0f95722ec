"""Block-diagonal matrices held as their blocks, stacked by size: what the condensed
linear part of several bodies is (each body's contact DOFs couple only among themselves;
a mistuned disk's 48 dampers beside its annulus), so that a product reads only the
blocks, and an inverse inverts each block. A sparse remainder holds what couples the
blocks weakly (at order 0 a whole disk's static condensation ties each damper to its
platforms: 1,920 entries beside 1,152^2 + 48 x 24^2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .condensation import real_product


def pattern_components(pattern: np.ndarray | sp.spmatrix) -> list[np.ndarray]:
    """The connected components of a square matrix's nonzero ``pattern`` (n, n), each as
    its positions, ascending."""
    n_comp, label = connected_components(sp.csr_matrix(pattern), directed=False)
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(n_comp + 1))
    return [order[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


@dataclass(frozen=True, eq=False)
class BlockDiagonal:
    """An (n, n) matrix that is block-diagonal after a permutation, up to a sparse
    remainder: per block size m its blocks' positions ``index`` (G, m) and the blocks
    (G, m, m); ``rest``: what lies outside them (scipy CSR), None where nothing does."""

    n: int
    index: tuple[np.ndarray, ...]
    blocks: tuple[np.ndarray, ...]
    rest: Any = None

    @classmethod
    def of(cls, A: np.ndarray, parts: list[np.ndarray] | None = None) -> BlockDiagonal:
        """A's blocks over ``parts`` (lists of positions covering 0..n-1 once; None: the
        components of A's pattern) and the rest of A (none where ``parts`` are those)."""
        parts = pattern_components(A != 0) if parts is None else parts
        by_size: dict[int, list[np.ndarray]] = {}
        for p in parts:
            by_size.setdefault(p.size, []).append(p)
        index = tuple(np.array(v) for v in by_size.values())
        outside = A.copy()
        for i in index:
            outside[i[:, :, None], i[:, None, :]] = 0
        rest = sp.csr_matrix(outside) if np.any(outside) else None
        return cls(A.shape[0], index, tuple(A[i[:, :, None], i[:, None, :]] for i in index),
                   rest)

    @property
    def largest(self) -> int:
        return max((i.shape[1] for i in self.index), default=0)

    @property
    def dtype(self) -> np.dtype:
        return np.result_type(*self.blocks) if self.blocks else np.dtype(float)

    @property
    def nbytes(self) -> int:
        rest = 0 if self.rest is None else self.rest.data.nbytes + self.rest.indices.nbytes
        return sum(a.nbytes for a in self.index + self.blocks) + rest

    def product(self, x: np.ndarray) -> np.ndarray:
        """A x for x (n,) or (n, k), real or complex (a real A's blocks stay real)."""
        xs = x.reshape(self.n, -1)
        out = np.zeros(xs.shape, dtype=np.result_type(self.dtype, x.dtype))
        for i, B in zip(self.index, self.blocks):
            out[i] = real_product(B, xs[i])
        if self.rest is not None:
            out += self.rest @ xs
        return out.reshape(x.shape)

    def inverse(self) -> BlockDiagonal:
        """The inverse, block by block (of a matrix with no rest); LinAlgError where a
        block is singular or its inverse not finite."""
        if self.rest is not None:
            raise ValueError("BlockDiagonal.inverse: the matrix is not block-diagonal")
        inv = tuple(np.linalg.inv(B) for B in self.blocks)
        if not all(np.all(np.isfinite(B)) for B in inv):
            raise np.linalg.LinAlgError("a diagonal block's inverse is not finite")
        return BlockDiagonal(self.n, self.index, inv)

    def sign(self) -> float:
        """sign det of a real matrix with no rest (the product of its blocks')."""
        if self.rest is not None:
            raise ValueError("BlockDiagonal.sign: the matrix is not block-diagonal")
        return float(np.prod([np.prod(np.linalg.slogdet(B)[0]) for B in self.blocks]))

    def dense(self) -> np.ndarray:
        """The (n, n) matrix."""
        out = np.zeros((self.n, self.n), dtype=self.dtype)
        for i, B in zip(self.index, self.blocks):
            out[i[:, :, None], i[:, None, :]] = B
        if self.rest is not None:
            out += self.rest.toarray()
        return out
