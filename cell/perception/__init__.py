"""What the camera sees becomes the cut (paper Sec. 5): depth image to cloud and surface mesh,
curvature (Eq. 11), the valley guideline, the generic model's affine fit and the interface it
predicts at depth.

Owns: ``pointcloud``, ``curvature``, ``guideline``, ``floor``, ``registration``,
``predicted``, ``interface``, ``params``, ``look``, ``pipeline``.
May import: the base modules of :mod:`cell`, :mod:`cell.robots`, :mod:`cell.tissue`.
"""
