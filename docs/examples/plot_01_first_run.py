"""
The first run: the baseline's equilibrium and pressure map
==========================================================

``fecheck run --plot DIR`` on the packaged baseline scene (the thesis's two condyle
spheres on flat plateaus, 800 N, the linear elastic foundation). The printed table is the
run's own output; the numbers are explained in :doc:`/getting-started`.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/first_run")
main(["run", "--plot", str(out)])

# %%
# What to look at: both plateau discs seen from above (the contact side, parallel view),
# +x (the subject's right) to the right and +y (anterior) up; in this right knee the
# medial compartment is the left disc (x < 0). Each face shows its mean EF contact
# pressure in MPa (viridis, the colour bar from 0 to the printed pointwise p_max); the
# black line is the edge of the faces in contact; each label gives the compartment's
# force and p_max; the scale bar is 10 mm. The lateral patch is the larger and its peak
# the higher: the load point lies lateral of the plateau centre.
image = plt.imread(out / "pressure_map.png")
plt.figure(figsize=(9, 9 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
