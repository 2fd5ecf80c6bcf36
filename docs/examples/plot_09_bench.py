"""
Benchmarks: run time against error, and contact detection
=========================================================

``fecheck bench --quick --plot DIR`` (the Pareto benchmark) and ``fecheck bench detection
--quick --plot DIR``, at their quick sizes. Times are measured in this build, on a machine
shared with other work: read the ratios, not the seconds.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/bench")
main(["bench", "--quick", "--plot", str(out)])
main(["bench", "detection", "--quick", "--plot", str(out)])

# %%
# The two Pareto plots, log-log: each method's median time per solve (s) against its
# relative error, the larger of the p_max and the contact-area errors (a fraction, not
# %), one line per method and compartment (circles medial, squares lateral), its points
# from coarse to fine meshes; the dashed black line is the Pareto front (nothing is both
# faster and more accurate). The first measures each model against its own converged
# reference (how well it is discretized), the second every model against the converged
# FE (how far the model is from the FE's answer): there the EF variants level off at
# their modelling error however fine the mesh.
for png in sorted(out.glob("bench_pareto_*.png")):
    image = plt.imread(png)
    plt.figure(figsize=(7, 7 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")

# %%
# Contact detection (thesis Figs. 3.21/3.25), one column per scenario (bisect, statics,
# sphere master, locality, mesh on mesh): on top the median time per detection call (ms)
# against the slave's faces, below the absolute area error against the exact area (a
# fraction), both log-log, one line per detection path (fecheck's closed form and BVH,
# the thesis stack's fcl, ray parity and ray casting). The tick labels of the faces axis
# crowd at these few sizes; read the values from the points.
image = plt.imread(out / "bench_detection.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
