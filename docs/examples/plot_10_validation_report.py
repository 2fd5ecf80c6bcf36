"""
The validation report's figures
===============================

``fecheck validate --quick --out DIR`` reruns every thesis table and figure group
(``validation/row_*.py``) at the quick sizes; its ``report.md`` is the
:doc:`/validation-report` page of this site, and these are its pictures.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main

out = Path("../_generated/validation")
main(["validate", "--quick", "--out", str(out)])

# %%
# Each row's PNG, named after the thesis's table or figure. The deviation charts give
# 100·(fecheck − thesis)/thesis in % per quantity (a bar per quantity, the row's
# tolerance shaded); the figure rows redraw the thesis's figure with fecheck's values
# (axes and units on each). The pressure maps are seen from above, +x (the subject's
# right) to the right, anterior up, pressure in MPa.
for png in sorted(out.glob("*.png")):
    image = plt.imread(png)
    plt.figure(figsize=(8, 8 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.title(png.stem)
    plt.axis("off")
plt.show()
