"""Environments the end-effector interacts with."""

from .base import Environment
from .elastic import ElasticPlane, LinearSpring

__all__ = ["Environment", "ElasticPlane", "LinearSpring"]
