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
# What to look at: one log-log panel per group, the error (relative, at each level)
# against the mesh size h (mm); a straight line's slope is the observed order, to compare
# with the expected order in the table above (patch tests sit at round-off, near 1e-12).
image = plt.imread(out / "verify.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
