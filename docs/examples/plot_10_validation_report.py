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
# Each row's PNG, titled with the file name (the thesis's table or figure). What to look
# at:
#
# - the ``table_5_*`` deviation charts: one horizontal bar per quantity (its unit in its
#   name), the deviation from the thesis in % (100·(fecheck − thesis)/thesis), blue for
#   fecheck's exact clipped faces and orange, where the thesis counted whole faces (its
#   Fig. 3.20), for fecheck counting the same way. Tables 5.1 and 5.2 show no bars: the
#   deviations there are zero to the printed digits;
# - ``table_3_1``: the mesh checks, thesis / fecheck per mesh and check, green where they
#   agree and red where they differ; ``table_2_*``: the plane angles (degrees) and the
#   mean fit errors (mm) of the surface fits, the thesis's scan beside the lenhart2015
#   knee;
# - the ``fig_*`` rows redraw the thesis's figures with fecheck's values: compartment and
#   ligament forces (N) or peak pressures (MPa) against the load point's shift along x
#   (mm, toward the lateral side), laws against depth (log-log), detection time and area
#   error against faces; the thesis's own values are drawn as stars, crosses or dashed
#   lines where it gives them;
# - ``fig_5_18``, ``fig_5_18_baseline`` and ``fig_5_21``: the tibial pressure (MPa, face
#   means, colour bar up to the printed p_max) seen from the contact side, x (the
#   subject's right) to the right, y anterior up, medial on the left of this right knee.
for png in sorted(out.glob("*.png")):
    image = plt.imread(png)
    plt.figure(figsize=(8, 8 * image.shape[0] / image.shape[1]))
    plt.imshow(image)
    plt.title(png.stem)
    plt.axis("off")
plt.show()
