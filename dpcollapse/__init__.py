"""dpcollapse: 2D free-surface viscoplastic granular flows (Drucker–Prager, μ(I)) on FEniCSx 0.5."""

__version__ = "0.1.0"
