"""URDF robot models: parse and check (``load_urdf``), forward kinematics (``Kinematics``).

Pure Python + numpy, no Zenoh (layer 1, beside ``zentf.ros``). ``.xacro`` files are expanded by zentf's own
confined xacro (``zentf.urdf.xacro``): a model file is data, never code.
"""
from __future__ import annotations

from .errors import URDFError
from .kinematics import Kinematics
from .model import (JOINT_TYPES, MOVABLE_TYPES, URDF, Box, Cylinder, Joint, JointLimit, JointMimic, Link,
                    Material, Mesh, Pose, Robot, Sphere, Visual)
from .parser import load_urdf, parse_urdf, read_urdf_text
from .resolve import PACKAGE_PATH_ENV
from .xacro.budget import BUDGET_OPTION as XACRO_BUDGET_OPTION
from .xacro.budget import DEFAULT_BUDGET as DEFAULT_XACRO_BUDGET
from .xacro.budget import Budget as XacroBudget
from .xacro.budget import parse_budget as parse_xacro_budget

__all__ = ["URDFError", "Kinematics", "JOINT_TYPES", "MOVABLE_TYPES", "URDF", "Robot", "Link", "Joint",
           "JointLimit", "JointMimic", "Visual", "Material", "Mesh", "Box", "Cylinder", "Sphere", "Pose",
           "load_urdf", "parse_urdf", "read_urdf_text", "PACKAGE_PATH_ENV", "XacroBudget", "parse_xacro_budget",
           "DEFAULT_XACRO_BUDGET", "XACRO_BUDGET_OPTION"]
