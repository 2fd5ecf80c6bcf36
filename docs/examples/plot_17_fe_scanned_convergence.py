"""
FE mesh convergence on the scanned knee
=======================================

``python validation/fe_scanned_convergence.py --quick --out DIR`` solves the FE of the
scanned femur on the scanned tibia on series of meshes (refined surfaces, finer sheets,
more levels through the thickness).
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_scanned_convergence").resolve()
command = [sys.executable, "-m", "validation.fe_scanned_convergence", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Left and middle: p_max (MPa; filled at the vertices, open on the EF
# faces) and the contact area (mm²) per compartment against the FE surface element size
# (mm), with the Richardson extrapolation where three levels exist (at --quick one
# level, so one point per series); right: the change (%) of p_max and area against 4
# levels of elements through the thickness, for 2 and 3 levels.
for png in [out / "fe_scanned_convergence.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
