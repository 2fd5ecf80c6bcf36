"""Statics: the equilibrium of rigid bodies by safeguarded block Newton, frames,
ligaments, contact interfaces, load control.

Owns rotations and twists, the Newton solver over the free coordinates of every body
(`newton`; the knee models' tibia is its one-body case), contact interfaces between two
bodies (`interfaces`), ligament rods and springs (to a fixed point or between two bodies),
the rigid point-contact statics and one-pair load control. Imports `scene`, `reference`,
`contact`, `laws` and `geometry`; knows no scene file.
"""
