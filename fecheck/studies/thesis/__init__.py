"""The thesis's tables and figures reproduced: one ``row_*`` module per group of them, each
with ``rows(quick, out) -> list[Row]`` (`report.Row`), the thesis's printed numbers
(`thesis_values`) and the fits of its §2.2 on the packaged knee (`knee_fits`).
`fecheck validate` (`fecheck.studies.validate`) runs the rows and writes the report; they
ship with the package, so it runs from an installed wheel.
"""
