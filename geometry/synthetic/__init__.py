"""Knees and implants built from formulas, for tests and validation scripts that must not
depend on scanned data: a smooth knee (`knee`), the same knee voxelized and meshed again
like a segmentation (`voxel_knee`), and a total knee replacement with a test cylinder
(`implant`). Units mm; thesis frame (x right, y anterior, z superior)."""
