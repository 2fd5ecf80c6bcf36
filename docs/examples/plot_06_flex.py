"""
Flexion: kinematics and contact paths
=====================================

``fecheck flex femur_tibia_ligaments --plot DIR`` from 0 to 60 degrees in steps of 10,
at the quick size (scanned sheets decimated to 1,500 faces), with the knee's ligament
bundles.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/flex")
main(["flex", "femur_tibia_ligaments", "--angles", "0:60:10",
      "--set", "scanned.decimate_faces=1500", "--plot", str(out)])

# %%
# ``kinematics.png``: against the flexion angle (degrees), the tibia's internal rotation
# and abduction (degrees), the translation of the tibial point at the flexion axis (mm),
# the compartment forces (N) and the ligament forces (N).
image = plt.imread(out / "kinematics.png")
plt.figure(figsize=(9, 9 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")

# %%
# ``contact_paths.png``: each compartment's centre of pressure on the tibial plateau,
# seen from above in the tibia frame (x right, y anterior, mm), one point per angle:
# how far each contact rolls back as the knee flexes.
image = plt.imread(out / "contact_paths.png")
plt.figure(figsize=(8, 8 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
