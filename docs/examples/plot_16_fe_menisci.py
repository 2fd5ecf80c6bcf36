"""
The FE of the knee with menisci: tibial pressure
================================================

``python validation/fe_menisci.py --quick --out DIR`` solves the FE of the knee with
menisci at its EF equilibrium (quick: decimated sheets).
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_menisci").resolve()
command = [sys.executable, "-m", "validation.fe_menisci", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: The FE's tibial contact pressure (MPa, colour bar) seen from above: x
# (mm) to the subject's right, y (mm) anterior up, medial on the left of this right
# knee; the white lines are the meniscus footprints, the labels each compartment's
# meniscal share of the load and p_max. Most of the load goes cartilage to cartilage
# inside the menisci.
for png in [out / "fe_menisci_pressure.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
