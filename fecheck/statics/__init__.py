"""Statics: the tibia's equilibrium by safeguarded Newton, frames, ligaments, load control.

Owns rotations and twists, the Newton solver, ligament rods and springs, the rigid
point-contact statics and one-pair load control. Imports `scene`, `reference`,
`contact`, `laws` and `geometry`; knows no scene file.
"""
