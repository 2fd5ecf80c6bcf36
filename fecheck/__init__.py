"""fecheck: elastic-foundation knee contact, cross-checked by finite elements.

Units: mm, N, MPa (N/mm²), N·mm, kg. Frame (thesis App. A/B): origin at the centre of
the tibial plateau, x to the subject's right, y anterior, z superior. The femur is
fixed; the tibia moves.
"""

__version__ = "0.1.0"
