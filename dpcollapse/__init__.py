"""dpcollapse: 2D free-surface viscoplastic granular flows (Drucker–Prager, μ(I)) on FEniCSx 0.5."""

from dpcollapse import wheel_mpi as _wheel_mpi

__version__ = "0.1.0"

_wheel_mpi.install()   # pip path only: MPI before DOLFINx (dpcollapse/wheel_mpi.py)
