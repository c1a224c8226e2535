"""Names of the cell's arms, sites, bodies and geoms as they stand in the compiled model.

Tools are attached to the arms under a prefix (``knife/``, ``gripper/``, ``camera/``); these
are the names the controllers, the runtime and the envs look up.

Example:
    >>> from cell.robots.names import ARMS, KNIFE_TIP
    >>> sorted(ARMS), KNIFE_TIP
    (['camera_arm', 'knife_arm', 'pull_arm'], 'knife/tip')
"""

from cell.robots.dh import KUKA_LWR4, VIPER_S1700D, ArmDescription

#: Arm prefix, description and tool of each robot of the cell.
ARMS: dict[str, ArmDescription] = {
    "knife_arm": VIPER_S1700D,
    "pull_arm": VIPER_S1700D,
    "camera_arm": KUKA_LWR4,
}
KNIFE_TIP = "knife/tip"
KNIFE_BLADE_GEOM = "knife/blade"
GRASP_SITE = "gripper/grasp"
GRIPPER_BODY = "gripper/gripper"
CAMERA = "camera/camera"
