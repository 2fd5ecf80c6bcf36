"""
The calibration table against the axisymmetric FE
=================================================

``python validation/ef_calibration_table.py --quick --out DIR`` fits the local power law's
exponent to the axisymmetric FE of a rigid sphere on a bonded layer over a grid of ν, h
and R.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/ef_calibration_table").resolve()
command = [sys.executable, "-m", "validation.ef_calibration_table", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Left: the exponent m of the FE's F = c·A^m against h/R, one point per
# ν (blue 0.3, orange 0.49); middle: the p_max error of the fitted law against the FE
# (%) against the FE contact radius over the thickness a/h, the grey band ±5 %; right:
# the FE's p_max/p_mean against the local exponent, the line p_max = m·p_mean.
for png in [out / "ef_calibration_table.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
