"""
Importing a knee: the preview
=============================

``fecheck knee import`` checks a knee's surface files and writes a scene and
``SCENE_preview.png``. Here it imports the shipped lenhart2015 knee's own files, as you
would import yours.
"""

from pathlib import Path

import matplotlib.pyplot as plt

from fecheck.cli import main
from fecheck.scene.packaged import data_dir

knee = data_dir("fecheck:knee/lenhart2015")
out = Path("../_generated/knee_import")
main(["knee", "import",
      "--femur", str(knee / "lenhart2015_R_femur_cartilage.stl"),
      "--tibia", str(knee / "lenhart2015_R_tibia_cartilage_medial.stl"),
      "--tibia-lateral", str(knee / "lenhart2015_R_tibia_cartilage_lateral.stl"),
      "--femur-bone", str(knee / "lenhart2015_R_femur_bone_distal60.stl"),
      "--tibia-bone", str(knee / "lenhart2015_R_tibia_bone_proximal40.stl"),
      "--units", "mm", "--side", "right", "-o", str(out / "my_knee.toml")])

# %%
# What to look at before running: three sections and a gap map, in mm in the thesis frame.
# Top left, the frontal section at y = 0 seen from behind (x, the subject's right, to the
# right; z superior up); bottom, the sagittal sections through the medial (x < 0 in this
# right knee) and the lateral compartment, seen from +x (y, anterior, to the right). In
# each the femoral surface is blue, the tibial red and the bones grey: the femur must
# rest on the tibia, not far above it nor deep through it. Top right, the rest gap from
# each tibial point to the femur, the tibia seen from above (x right, y anterior up):
# blue where the surfaces are apart (mm), red where they overlap (< 0), the solid contour
# at 0 mm and the dashed one at 1 mm; the dotted lines are the section planes. The
# contact will start in the red patches; a gap map that is all blue or all red means a
# wrong frame or unit.
image = plt.imread(out / "my_knee_preview.png")
plt.figure(figsize=(10, 10 * image.shape[0] / image.shape[1]))
plt.imshow(image)
plt.axis("off")
plt.show()
