"""A frame provider for the tests of the hybrids with a moving contact frame: one fixed normal and tangent plane."""

from __future__ import annotations

import numpy as np


class ConstantFrame:
    """A frame provider that always returns one normal and tangent plane (base frame)."""

    SIGNALS = ()

    def __init__(self, n, t):
        self.n, self.t = np.asarray(n, dtype=float), np.asarray(t, dtype=float)

    def update(self, force, velocity, x=None):
        return self.n

    def selection(self):
        return self.n[:, None], np.column_stack([self.t, np.cross(self.n, self.t)])

    def reset(self):
        pass

    def signals(self):
        return {}

    def describe(self):
        return {"type": "constant"}
