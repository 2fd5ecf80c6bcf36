"""FE: the finite-element cross-check of the elastic-foundation answer (scikit-fem).

Owns the layer meshes' solves (3D quadratic tets, axisymmetric), exact frictionless
contact, pressure recovery and the EF-vs-FE comparison. Imports `scene`, `reference`,
`laws`, `statics`, `model` and `geometry`; scikit-fem is imported lazily.

Subpackages, each importing only itself and those before it: `material` → `contact` →
`pressure` → `bodies` → `solve` → `reference` → `knee`.
"""
