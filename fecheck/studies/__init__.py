"""Studies: benchmarks, the stress matrix, sweeps and the validation report runner.

Run many models and compare them; they compute no mechanics of their own. May import
every stage before them (scene … fe, io) and `geometry`.
"""
