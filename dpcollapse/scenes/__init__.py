"""Scenes: the initial mass, its boundaries and what is measured on it (``scenes.base``).

One module per scene; ``scenes.registry.scene(cfg)`` finds the scene of
``geometry.shape`` among the modules of this package.
"""
