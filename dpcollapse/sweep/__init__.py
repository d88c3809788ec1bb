"""Batch sweeps: many runs of one base config, each a ``dpcollapse run`` subprocess.

``spec`` reads and validates a sweep file into cases, ``naming`` names their run
directories, ``executors`` runs them (local processes, ``mpi4py.futures``, a SLURM job
array), ``collect`` writes ``sweep.csv`` from the run directories, ``plot`` draws a result
against a parameter. Nothing here imports DOLFINx: the driver only starts subprocesses.
"""
