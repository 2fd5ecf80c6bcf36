"""The contact solves under load control, assembled from the contact core: tibial layers
with the tibia's free DOFs (`joint`), pressed by the joint path's drive with its
candidate rounds (`press`), and any deformable bodies with one rigid indenter
(`multibody`)."""
