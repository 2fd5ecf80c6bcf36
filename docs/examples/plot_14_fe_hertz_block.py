"""
FE on a thick block against Hertz
=================================

``python validation/fe_hertz_block.py --quick --out DIR`` presses the medial condyle
sphere on a 60 mm block (contact radius / thickness about 0.04) and compares the FE
pressure with Hertz (quick: the axisymmetric FE only).
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_hertz_block").resolve()
command = [sys.executable, "-m", "validation.fe_hertz_block", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: The contact pressure (MPa) against the radius r (mm) from the contact
# centre: the axisymmetric FE (solid) should lie on Hertz's semi-ellipse (dashed), with
# the same peak and the same contact radius; the small wiggle at the edge is the FE's
# last contact node.
for png in [out / "fe_hertz_block.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
