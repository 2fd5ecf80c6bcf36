"""Finite-element cross-check of the elastic-foundation answer (scikit-fem)."""
