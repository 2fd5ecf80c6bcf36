"""
The calibrated EF against the FE on held-out loads
==================================================

``python validation/ef_calibrated.py --quick --out DIR`` fits the calibrated EF law to
each study scene's FE and compares EF laws (linear, Blankevoort, calibrated) with the FE
at a load and a load point no fit saw.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/ef_calibrated").resolve()
command = [sys.executable, "-m", "validation.ef_calibrated", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: one group of bars per scene (at --quick the baseline, at its own load
# point and with the load point moved 5 mm in x), one bar per EF law (linear,
# Blankevoort, calibrated on the scene, calibrated from the built-in table): the worst
# ``|EF/FE − 1|`` of p_max (%), of the contact area (%), and the absolute medial-share
# difference EF − FE (percentage points), at a load and a load point no fit saw. The
# dashed lines are the targets; the calibrated law's bars should be the shortest.
for png in [out / "ef_calibrated.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
