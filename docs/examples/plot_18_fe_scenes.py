"""
EF against the FE of the same scene, on every kind of scene
===========================================================

``python validation/fe_scenes.py --quick --out DIR`` runs the FE cross-check on the
baseline and its variants, the inclined and polynomial plateaus and the scanned knee.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_scenes").resolve()
command = [sys.executable, "-m", "validation.fe_scenes", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: One row per scene (at --quick the baseline and the scanned femur-
# tibia knee decimated to ~1,500 faces): left, EF/FE − 1 (%) of p_max, p_max on the EF
# faces, area and p_mean, per compartment (filled medial, open lateral); middle, the
# medial-share difference EF − FE (percentage points); right, the distance between the
# EF and FE centres of pressure (mm). The grey bands are the tolerances within which the
# EF is trusted.
for png in [out / "fe_scenes.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
