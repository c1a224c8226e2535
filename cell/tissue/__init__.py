"""The meat: muscle shapes and their tetrahedral meshes, materials and the paper's spring law,
the mass-spring forces, the aponeurosis bindings and the measured cutting force.

Owns: ``shape``, ``geometry``, ``tetmesh``, ``flexcomp``, ``curves``, ``material``,
``materialfile``, ``springlaw``, ``packedlaw``, ``lattice``, ``massspring``, ``aponeurosis``,
``forces`` (the two together, as the simulation applies them), ``forcecurve``.
May import: the base modules of :mod:`cell`. The modules that the rheology side uses
(``curves``, ``material``, ``springlaw``, ``packedlaw``, ``lattice``, ``tetmesh``) do not import
MuJoCo.
"""
