"""Names and physical constants every stage shares, each written once.

Frame and units: mm, N, MPa; origin at the tibial plateau centre, x to the subject's
right, y anterior, z superior.
"""

COMPARTMENTS = ("medial", "lateral")
"""The two tibio-femoral compartments, in the order every table uses."""

LIGAMENTS = ("ACL", "PCL", "MCL")
"""The three ligaments of the thesis's knee model (thesis Table B.1)."""

DOF_NAMES = ("x", "y", "z", "abduction", "internal")
"""The tibia's generalised coordinates q = (x, y, z mm, θy, θz rad); θx (flexion) is driven."""

MODEL_KINDS = ("rigid", "sphere-plane", "sphere-tibia", "femur-tibia")
"""Model kinds a scene may select (`model.kind`)."""

GRAVITY_MPS2 = 9.81
"""Gravitational acceleration, m/s²: a mass in kg weighs mass · 9.81 N."""
