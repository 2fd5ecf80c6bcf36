"""
Passive flexion of the scanned knee
===================================

``python validation/flex_passive.py --quick --out DIR`` flexes the scanned knee with its
ligament bundles under variants of the load, the flexion axis and the bundles.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/flex_passive").resolve()
command = [sys.executable, "-m", "validation.flex_passive", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Against knee flexion (degrees), one line per load variant (800 N or
# 30 N, fixed in space or along the tibial axis): left, the tibial internal rotation
# (degrees) with the published passive flexion of the same knee as black squares; middle
# and right, the medial and lateral centre of pressure (solid) and the flexion-facet
# centre (dashed), y in mm in the tibia frame (anterior +). The panel titles give the
# published directions (screw-home, medial 2-4 mm and lateral 15-20 mm posterior).
for png in [out / "flex_passive.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
