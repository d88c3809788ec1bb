"""Reduced (cheaper) models of the same scenes, independent of the finite-element solvers."""
