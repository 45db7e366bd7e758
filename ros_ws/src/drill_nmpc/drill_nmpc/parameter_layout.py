"""Named parts of a parameter vector, in order: the one definition that slices the NLP's
parameter symbols and packs its numbers."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ParameterLayout:
    """Named parts of the NLP's parameter vector, in order: the one definition the symbols
    (``split``) and the numbers (``pack``) both follow."""
    sizes: tuple[tuple[str, int], ...]

    @property
    def size(self) -> int:
        return sum(n for _, n in self.sizes)

    def split(self, p) -> dict:
        out, offset = {}, 0
        for name, n in self.sizes:
            out[name] = p[offset:offset + n]
            offset += n
        return out

    def pack(self, **values) -> np.ndarray:
        parts = []
        for name, n in self.sizes:
            v = np.asarray(values[name], dtype=float).ravel()
            if v.size != n:
                raise ValueError(f"parameter {name}: {v.size} values, expected {n}")
            parts.append(v)
        return np.concatenate(parts)
