"""
The scanned-knee scenes and their pressure maps
===============================================

``python validation/scanned_tables.py --quick --out DIR`` runs the scanned-knee scenes
beside the thesis's Tables 5.9-5.11 and draws the tibial cartilage pressure of the scanned
models (thesis Figs. 5.18, 5.21).
"""

import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt

out = Path("../_generated/scanned_tables").resolve()
command = [sys.executable, "-m", "validation.scanned_tables", "--quick", "--out", str(out)]
done = subprocess.run(command, cwd="../..", capture_output=True, text=True, check=True)
print(done.stdout)

# %%
# What to look at: Each scanned model's tibial cartilage pressure (MPa, face means,
# colour bar from 0 to the printed p_max) seen from above (x right, the lateral side of
# this right knee; y anterior up), the tibial bone drawn grey around the cartilage so
# that the eminence shows; the title gives each compartment's force and p_max. One
# picture per scanned scene it runs (sphere_tibia, femur_tibia, femur_tibia_ligaments).
for png in sorted(out.glob("*.png")):
    image = plt.imread(png)
    plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.axis("off")
plt.show()
