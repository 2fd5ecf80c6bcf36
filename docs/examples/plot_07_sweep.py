"""
A sweep: forces and peak pressures against the load point
=========================================================

``fecheck sweep --param 'load.point_mm[0]' --values=-8:8:5 --plot DIR`` on the baseline:
the load moved from 8 mm medial to 8 mm lateral of the plateau centre.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/sweep")
main(["sweep", "--param", "load.point_mm[0]", "--values=-8:8:5", "--plot", str(out)])

# %%
# Each compartment's contact force (N) against the swept value (here the load point's x,
# mm): the load moves from the medial to the lateral compartment as the point moves
# toward +x.
for name in ("sweep_force_N.png", "sweep_max_pressure_MPa.png"):
    image = plt.imread(out / name)
    plt.figure(figsize=(6, 6 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")

# %%
# The second picture is each compartment's peak pressure (MPa) against the same value.
plt.show()
