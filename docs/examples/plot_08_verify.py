"""
Verification: error against mesh size
=====================================

``fecheck verify --quick --only ... --out DIR``: some of the code-verification cases at
their quick levels (the manufactured solutions, the patch tests, the EF's mesh
independence and the thin layer); ``fecheck verify --quick`` runs them all.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/verify")
main(["verify", "--quick", "--only", "manufactured", "patch", "EF mesh", "thin-layer",
      "--out", str(out)])

# %%
# What to look at: one log-log panel per group, the relative error at each level (or the
# change between successive levels, Δ) against that group's mesh size h: 1 / cells per
# side for the manufactured solutions, the relative face size or element size (mm) for
# the EF, the layer thickness over the contact radius h/a for the thin layer. Each
# case's line is labelled with its observed order p; the dotted line beside it has the
# expected slope. The patch tests are exact to round-off at one level: they are in the
# printed table, not in the picture.
image = plt.imread(out / "verify.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
