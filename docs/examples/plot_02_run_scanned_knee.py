"""
The scanned knee: pressure on the tibial cartilage
==================================================

``fecheck run femur_tibia --plot DIR``: the femoral cartilage of the lenhart2015 right knee
(MRI-derived, shipped with fecheck) on its two tibial cartilage sheets, mesh on mesh, with
the bone-distance thickness map.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/scanned_knee")
main(["run", "femur_tibia", "--plot", str(out)])

# %%
# What to look at: the two tibial cartilage sheets seen from above (parallel view), +x
# (the subject's right) to the right and +y (anterior) up; medial is the left sheet in
# this right knee. Each face shows its mean EF contact pressure in MPa (colour bar from 0,
# which is also every face out of contact, to the printed pointwise p_max); the black line
# is the edge of the faces in contact; the labels give each compartment's force and
# p_max; the scale bar is 10 mm. The contact patches are irregular because the scanned
# surfaces are, and here the medial compartment carries more load at a higher peak.
image = plt.imread(out / "pressure_map.png")
plt.figure(figsize=(9, 9 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
