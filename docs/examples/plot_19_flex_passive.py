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
# What to look at: Against knee flexion (degrees): the tibia's internal rotation
# (degrees) and the medial and lateral contact's anteroposterior position (mm, tibia
# frame), one line per variant, beside the published screw-home and medial-pivot
# directions.
for png in [out / "flex_passive.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
