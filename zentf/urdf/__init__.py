"""URDF robot models: parse and check (``load_urdf``), forward kinematics (``Kinematics``).

Pure Python + numpy, no Zenoh (layer 1, beside ``zentf.ros``). ``.xacro`` needs the optional extra.
"""
from __future__ import annotations

from .errors import URDFError
from .kinematics import Kinematics
from .model import (JOINT_TYPES, MOVABLE_TYPES, URDF, Box, Cylinder, Joint, JointLimit, JointMimic, Link,
                    Material, Mesh, Pose, Robot, Sphere, Visual)
from .parser import load_urdf, parse_urdf, read_urdf_text
from .resolve import PACKAGE_PATH_ENV

__all__ = ["URDFError", "Kinematics", "JOINT_TYPES", "MOVABLE_TYPES", "URDF", "Robot", "Link", "Joint",
           "JointLimit", "JointMimic", "Visual", "Material", "Mesh", "Box", "Cylinder", "Sphere", "Pose",
           "load_urdf", "parse_urdf", "read_urdf_text", "PACKAGE_PATH_ENV"]
