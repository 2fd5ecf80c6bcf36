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
# ``kinematics.png``, four panels against the knee flexion (degrees): top left, the
# tibia's internal rotation and abduction (degrees); top right, the translation of the
# tibial point at the flexion axis (mm: medio-lateral along the axis, anterior,
# superior); bottom left, the medial and lateral contact forces (N); bottom right, the
# ligament tensions (N) per ligament group. The title gives the flexion axis (here
# fitted through the centres of spheres fitted to the posterior condyles).
image = plt.imread(out / "kinematics.png")
plt.figure(figsize=(9, 9 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")

# %%
# ``contact_paths.png``: each compartment's centre of pressure on the tibial sheets
# (grey mesh), seen from above in the tibia frame (x right, y anterior, mm), one marker
# per angle (circles medial, squares lateral) coloured by the flexion angle (degrees,
# colour bar): how far each contact travels as the knee flexes.
image = plt.imread(out / "contact_paths.png")
plt.figure(figsize=(8, 8 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
