"""Errors that end a run, each with the exit status a batch script can branch on.

| status | meaning |
| --- | --- |
| 0 | done |
| 2 | bad input (config, command line, missing file) |
| 3 | the nonlinear solver did not converge, even at the smallest time step |
| 4 | the mesh inverted or degenerated and could not be repaired by remeshing |
| 5 | an I/O failure during the run (disk full, permissions, a file removed under it) |
| 1 | a bug: one line, the traceback in ``error.log`` (run directory, or the temp dir) |
| 130 | interrupted (Ctrl-C / SIGTERM); the run directory stays valid and can be resumed |
"""


class DpcollapseError(Exception):
    """Base class: a one-line message for the user and an exit status."""

    exit_code = 1


class ConfigError(DpcollapseError):
    """Bad input: names the key path, the value given and what is allowed."""

    exit_code = 2


class ConvergenceError(DpcollapseError):
    """The nonlinear solve of a time step failed at the smallest allowed Δt."""

    exit_code = 3


class MeshError(DpcollapseError):
    """A cell inverted, or the domain degenerated beyond repair."""

    exit_code = 4


class OutputError(DpcollapseError):
    """Reading or writing the run's files failed during the run (disk full, permissions)."""

    exit_code = 5


class InternalError(DpcollapseError):
    """A bug: the message points at the log file that holds the traceback."""

    exit_code = 1


class Interrupted(DpcollapseError):
    """The run was stopped by a signal; what it wrote is valid and resumable."""

    exit_code = 130
