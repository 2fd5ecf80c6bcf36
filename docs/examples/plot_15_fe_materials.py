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
# What to look at: The deviation (%) of the EF (red) and of Hertz (green) from the FE,
# for p_max (left) and the contact area (right), against the FE contact radius over the
# layer thickness (log), solid for ν 0.3 and dashed for ν 0.45; the grey band is ±10 %.
# The EF approaches the FE where the layer is thin against the contact (large a/h) at ν
# 0.3; Hertz where it is thick (small a/h); at ν 0.45 the EF stays far off.
for png in [out / "fe_thickness.png"]:
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
