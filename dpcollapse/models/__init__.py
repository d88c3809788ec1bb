"""Models: what is solved on a domain, step by step (``models.base``); ``models.stokes``
holds the regularized and augmented-Lagrangian Stokes models."""
