"""Shared fixtures."""

from __future__ import annotations

import math

import numpy as np
import pytest

import forcecontrol as fc


@pytest.fixture(scope="session")
def arm() -> fc.PlanarTwoLink:
    """The chapter's arm with its data."""
    return fc.PlanarTwoLink()


@pytest.fixture(scope="session")
def q_contact() -> np.ndarray:
    """Elbow-up posture with the tip at [1, 0] (the chapter's start), q0 = [π/3, −2π/3]."""
    return np.array([math.pi / 3, -2 * math.pi / 3])
