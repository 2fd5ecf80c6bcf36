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
# The Pareto plots: each method's run time (s, log) against its error (%, log) against
# the converged reference, per compartment: lower left is better; a method's points go
# from coarse to fine meshes.
for png in sorted(out.glob("bench_pareto_*.png")):
    image = plt.imread(png)
    plt.figure(figsize=(7, 7 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")

# %%
# Contact detection (thesis Figs. 3.21/3.25): time against the number of faces for
# fecheck's engine and the thesis stack, and the area and depth errors against exact
# values.
image = plt.imread(out / "bench_detection.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
