"""mink IK controllers of the cell's three arms and the plans they follow: the knife's cut
(:class:`~controllers.knife.CutPlan`), the gripper's grasp and pull
(:class:`~controllers.gripper.PullPlan`), the camera's view.

May import: the base modules of :mod:`cell`, :mod:`cell.robots`, :mod:`cell.tissue`,
:mod:`cell.perception`; never :mod:`cell.sim`, :mod:`envs` or the benches.
"""
