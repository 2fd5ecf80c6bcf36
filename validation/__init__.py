"""The validation scripts: one per thesis table or figure group and per study.

A package so that the scripts import one another by name (``from validation import
report``); each still runs as a file (``python validation/row_rigid.py --quick``) or as a
module (``python -m validation.row_rigid --quick``, from the repository root). It
imports `fecheck` and `geometry`; neither imports it (``tests/test_architecture.py``).
"""
