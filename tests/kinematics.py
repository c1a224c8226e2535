"""Forward kinematics from the DH tables: the reference the arm tests check the MJCF arms
against."""

from __future__ import annotations

import numpy as np

from cell.errors import InputError
from cell.robots.dh import ArmDescription, dh_transform


def forward_kinematics(arm: ArmDescription, q: np.ndarray | tuple[float, ...]) -> np.ndarray:
    """Pose of the flange frame (frame N) in the base frame (frame 0).

    Args:
        arm: the arm.
        q: joint angles, in rad, one per joint.

    Returns:
        4x4 homogeneous transform, translation in m.

    Example:
        >>> from cell.robots.dh import KUKA_LWR4
        >>> forward_kinematics(KUKA_LWR4, np.zeros(7))[:3, 3]
        array([0.    , 0.    , 1.1785])
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (arm.dof,):
        raise InputError(None, "q", f"{arm.name} needs {arm.dof} joint angles, got shape {q.shape}")
    pose = np.eye(4)
    for joint, qi in zip(arm.joints, q, strict=True):
        pose = pose @ dh_transform(joint, float(qi))
    return pose
