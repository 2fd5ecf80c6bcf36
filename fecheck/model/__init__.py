"""Model: a scene assembled into contact pairs, loads and ligaments, solved, reported.

Owns the runners per model kind (rigid, sphere-plane, scanned), meshing sized from the
expected contact, notes and results. Entry point: `fecheck.model.run.run_scene`.
Imports every stage before it (scene, reference, contact, laws, statics) and `geometry`.
"""
