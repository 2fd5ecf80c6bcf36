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
# load (N); middle: against the meniscal modulus (MPa) at 800 N; right: the medial p_max
# (MPa) and contact area (mm²) with and without the medial meniscus, with the cadaver
# ratios in the title.
for png in [out / "menisci_study.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
