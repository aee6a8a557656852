"""Environments the end-effector interacts with."""

from .base import Environment
from .elastic import ElasticPlane, LinearSpring
from .rigid import (
    CircleConstraint,
    HolonomicConstraint,
    JointConstraint,
    OperationalConstraint,
    PlaneConstraint,
    RigidEnvironment,
)
from .spatial import ConstantWrench, SpatialSpring, Table

__all__ = [
    "Environment",
    "ElasticPlane",
    "LinearSpring",
    "RigidEnvironment",
    "HolonomicConstraint",
    "OperationalConstraint",
    "PlaneConstraint",
    "CircleConstraint",
    "JointConstraint",
    "SpatialSpring",
    "Table",
    "ConstantWrench",
]
