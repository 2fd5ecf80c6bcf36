"""Reference: the closed forms every stage compares with (EF cap, Hertz, Donahue 2002).

Written once here and imported everywhere else. Imports only `fecheck.errors`.
"""
