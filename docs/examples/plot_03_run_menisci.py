"""
The knee with menisci: tibial and meniscal pressure
===================================================

``fecheck run femur_tibia_menisci --plot DIR``, at the quick size (each scanned sheet
decimated to 1,500 faces): each meniscus is a free rigid body in EF contact with both
cartilages, held by its meniscal ligaments.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/menisci")
main(["run", "femur_tibia_menisci", "--set", "scanned.decimate_faces=1500",
      "--plot", str(out)])

# %%
# What to look at: two maps, one above the other, of the tibial cartilage seen from above
# (+x, the subject's right, to the right; +y anterior up; medial on the left in this
# right knee). The upper map is the cartilage-cartilage contact pressure (femur on tibia),
# the lower one the meniscus-tibia contact pressure, both in MPa on the same colour bar
# (face means, from 0 to the printed p_max). The red line is the edge of each meniscus's
# footprint (its volume projected on x-y at the solved pose), drawn on both maps; the
# black line the edge of the faces in contact. The lower map's labels give the load each
# meniscus carries and its share of the compartment's load: most of the load here goes
# cartilage to cartilage, inside the menisci's inner edge.
image = plt.imread(out / "pressure_map.png")
plt.figure(figsize=(9, 9 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
