"""Validation cases: the 2D solver against reference solutions."""
