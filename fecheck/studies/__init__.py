"""Studies: benchmarks, the stress matrix, sweeps, the EF calibration, the knee import and the
validation report runner.

Run many models and compare them; they compute no mechanics of their own. May import
every stage before them (scene … fe, io) and `geometry`.
"""
