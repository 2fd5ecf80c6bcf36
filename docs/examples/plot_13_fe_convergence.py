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
# What to look at: Log-log: the |relative error| of p_max, contact area and depth
# against the finest axisymmetric solution, against the element size under the contact
# (mm): the slope is the observed order. The last panel is the wall time per solve (s)
# against the dofs: its slope is the cost exponent.
for png in [out / "fe_convergence.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
