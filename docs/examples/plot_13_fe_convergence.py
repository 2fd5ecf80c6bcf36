"""
FE mesh convergence on the baseline compartments
================================================

``python validation/fe_convergence.py --quick --out DIR`` solves both baseline
compartments with the general 3-D FE path at a ladder of element sizes and compares with
the finest axisymmetric solution.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_convergence").resolve()
command = [sys.executable, "-m", "validation.fe_convergence", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Log-log, for the medial compartment: the absolute relative error of p_max
# (left) and of the contact area (middle) against the finest axisymmetric solution,
# against the element size under the contact (mm), for the 3-D FE (blue) and the
# axisymmetric model (orange): the slopes are the observed orders. Right: the wall time
# per 3-D solve (s) against the dofs, with the fitted cost exponent k in the legend (at
# --quick only two sizes, so k is rough).
for png in [out / "fe_convergence.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
