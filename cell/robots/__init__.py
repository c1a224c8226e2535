"""The cell's machines: DH tables, arms built from them, tools and the camera rig, and the
names they carry in the compiled model.

Owns: ``dh`` (kinematic tables), ``arms`` (MjSpec arms), ``servos`` (the joint servos'
sizing), ``tools`` (knife, gripper, camera on their flanges), ``camera`` (offscreen rendering
of the cell's camera), ``names`` (arm prefixes, site, body and geom names).
May import: the base modules of :mod:`cell` (errors, io, config, collision).
"""
