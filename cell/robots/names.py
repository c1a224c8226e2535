"""Names of the cell's arms, sites, bodies and geoms as they stand in the compiled model.

Tools are attached to the arms under a prefix (``knife/``, ``gripper/``, ``camera/``); these
are the names the controllers, the runtime and the envs look up.

Example:
The arms themselves (``knife_arm/``, ``pull_arm/``, ``camera_arm/``) are the scenario's
choice (:class:`cell.robots.choice.ArmsParams`).

    >>> from cell.robots.names import KNIFE_TIP
    >>> KNIFE_TIP
    'knife/tip'
"""

KNIFE_TIP = "knife/tip"
KNIFE_BLADE_GEOM = "knife/blade"
GRASP_SITE = "gripper/grasp"
GRIPPER_BODY = "gripper/gripper"
CAMERA = "camera/camera"
