"""The meat: muscle shapes and their tetrahedral meshes, materials and the paper's spring law,
the mass-spring forces, the aponeurosis bindings and the knife's cutting force.

Owns: ``shape``, ``geometry``, ``tetmesh``, ``flexcomp``, ``curves``, ``material``,
``materialfile``, ``springlaw``, ``packedlaw``, ``lattice``, ``massspring``, ``aponeurosis``,
``forces`` (the two together, as the simulation applies them), ``forcecurve``, ``cutmodel``
(the cutting model), ``seamcut`` (it on the cell's seam), ``cutting`` (the blade's load and
its reaction on the tissue).
May import: the base modules of :mod:`cell`. The modules that the rheology side uses
(``curves``, ``material``, ``springlaw``, ``packedlaw``, ``lattice``, ``tetmesh``) do not import
MuJoCo.
"""
