"""Environments the end-effector interacts with."""

from .base import Environment
from .elastic import ElasticPlane, LinearSpring
from .friction import FrictionalContact
from .mesh import ElasticMesh
from .rigid import (
    CircleConstraint,
    HolonomicConstraint,
    JointConstraint,
    OperationalConstraint,
    PlaneConstraint,
    RigidEnvironment,
)
from .spatial import ConstantWrench, SpatialSpring, Table
from .surfaces import ElasticCylinder, ElasticSphere, ElasticSurface, HeightField

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
    "ElasticSurface",
    "ElasticSphere",
    "ElasticCylinder",
    "HeightField",
    "ElasticMesh",
    "FrictionalContact",
]
