"""Manipulator models: the chapter's arm in closed form (and, with extras, URDF robots)."""

from .base import RobotModel, RobotTerms
from .planar_2r import CHAPTER_ARM, PlanarTwoLink, PlanarTwoLinkParameters

__all__ = ["RobotModel", "RobotTerms", "PlanarTwoLink", "PlanarTwoLinkParameters", "CHAPTER_ARM"]
