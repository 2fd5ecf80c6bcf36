"""
The FE cross-check: EF and FE pressure and their difference
===========================================================

``fecheck fe femur_tibia --plot DIR`` at the quick size (scanned sheets decimated to
1,500 faces), without the error estimate's coarse solve to keep the example short. The
printed report is the FE against the EF per compartment.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/fe")
main(["fe", "femur_tibia", "--set", "scanned.decimate_faces=1500", "--no-estimate",
      "--plot", str(out)])

# %%
# What to look at: three panels of the tibial sheets seen from above (+x, the subject's
# right, to the right; anterior up; medial left): the EF pressure, the FE pressure
# averaged on the same faces, both in one colour scale (MPa; capped at the smoothed FE
# peak when a lone FE spike would swamp it, as the title says), and FE − EF (MPa, a
# diverging scale centred on zero: red where the FE presses harder). The markers are each
# compartment's centre of pressure. The FE spreads the load wider than the EF (the
# layer's shear couples neighbouring points), so the difference is negative at the EF's
# peak and positive around its rim.
image = plt.imread(out / "fe_pressure_map.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
