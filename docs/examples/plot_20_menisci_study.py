"""
Meniscal load share of the EF knee with menisci
===============================================

``python validation/menisci_study.py --quick --out DIR`` solves the EF knee with menisci
over loads and meniscal moduli, and without the medial meniscus.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/menisci_study").resolve()
command = [sys.executable, "-m", "validation.menisci_study", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Left: the meniscal share of each compartment's load (%) against the
# load (N); middle: against the meniscus modulus (MPa, log) at 800 N; the grey bands are
# the published 40-70 % for intact knees. Right: the medial tibial p_max (MPa, blue) and
# contact area (mm², orange) intact and after a medial meniscectomy, with the ratios and
# the cadaver ranges in the title.
for png in [out / "menisci_study.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
