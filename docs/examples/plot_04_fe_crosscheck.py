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
# What to look at: three maps, one above the other, of the tibial sheets seen from above
# (tibia frame, parallel view: +x, the subject's right, to the right; +y anterior up;
# medial on the left in this right knee). Top, the EF pressure on the EF faces; middle,
# the FE pressure averaged onto the same faces: both in MPa on one colour bar (0 to the
# largest face mean; the title says when a lone FE spike caps it). Bottom, FE − EF in MPa
# on a diverging bar centred on 0: red where the FE presses harder, blue where the EF
# does. Lines: the surface edge black, the FE contact edge orange, the EF contact edge
# magenta; the centres of pressure are a black + (FE) and a magenta × (EF), their
# distance in the bottom labels. Here the FE's peak is lower than the EF's (blue at the
# EF's peak) and its contact reaches a little beyond the EF's edge.
image = plt.imread(out / "fe_pressure_map.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
