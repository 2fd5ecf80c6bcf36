"""
EF, Hertz and FE against material and thickness
===============================================

``python validation/fe_materials.py --quick --out DIR`` compares the EF law and Hertz with
the axisymmetric FE over Poisson's ratio, Young's modulus and the layer thickness.
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/fe_materials").resolve()
command = [sys.executable, "-m", "validation.fe_materials", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: The deviation (%) of EF and Hertz from the FE, for p_max and contact
# area, against the FE contact radius over the layer thickness (a/h), for ν 0.3 and
# 0.45: the EF holds for thin layers (large a/h), Hertz for thick ones (small a/h).
for png in [out / "fe_thickness.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
