"""SIGINT and SIGTERM while a run is being set up: an interrupt (exit 130, one line).

The handler raises :class:`KeyboardInterrupt` where that is safe, defers it where it is not,
and remembers that the signal came (:func:`received`): the time loop honours a signal whose
exception was lost (``Simulation.run`` stops after its first accepted step), and an error
that follows the signal is reported as the interrupt.
"""

from __future__ import annotations

import os
import signal
import threading

#: Set once SIGINT/SIGTERM arrived: an error after it is the interrupt's (a C extension's
#: import interrupted by the signal fails with "ImportError: initialization failed").
_signalled = False

#: Python packages whose code C/C++ calls back into (DOLFINx's wrappers around nanobind
#: calls that take Python callables, its JIT through FFCx and cffi, PETSc, gmsh): an
#: exception raised there unwinds through C++ frames (seen on the pip path's DOLFINx 0.11:
#: "double free or corruption", SIGSEGV, with SIGTERM 1 s into the set-up).
_CALLBACK_PACKAGES = ("dolfinx", "basix", "ffcx", "ufl", "cffi", "petsc4py", "gmsh",
                      "setuptools", "distutils")


def received() -> bool:
    """Whether SIGINT or SIGTERM arrived in this process since :func:`install`."""
    return _signalled


def _finalizer(code) -> bool:
    """Whether ``code`` runs a finalizer: ``__del__`` or a ``weakref.finalize`` callback
    (``tempfile.TemporaryDirectory``'s clean-up is one). Python prints an exception raised
    there as "Exception ignored in …" and goes on: the interrupt would be lost (seen in CI,
    SIGTERM during the set-up: the run went on to the end, exit 0)."""
    return code.co_name == "__del__" or (code.co_name == "__call__"
                                         and code.co_filename.endswith("weakref.py"))


def deferred(frame) -> bool:
    """Whether an exception raised in ``frame`` would not reach our code as raised: a frame
    of its chain is the import machinery's (also the Python code that a C extension's
    initialization calls), a library's that C/C++ may have called (``_CALLBACK_PACKAGES``,
    judged by module name), or a finalizer's."""
    while frame is not None:
        code = frame.f_code
        if code.co_filename.startswith("<frozen importlib") or _finalizer(code):
            return True
        if str(frame.f_globals.get("__name__", "")).partition(".")[0] in _CALLBACK_PACKAGES:
            return True
        frame = frame.f_back
    return False


def interrupt(signum, frame):
    """The handler: raise KeyboardInterrupt in our own code; elsewhere deliver the signal
    again 10 ms later. Not during an import: inside the import machinery's module locks an
    exception is printed as a traceback, and inside a nanobind module's initialization
    (DOLFINx >= 0.9 builds its enums by calling Python's enum module) it becomes a C++
    nanobind::python_error that ends in std::terminate (SIGABRT); nor inside the libraries'
    code, nor in a finalizer (:func:`deferred`)."""
    global _signalled
    _signalled = True
    if deferred(frame):
        threading.Timer(0.01, signal.raise_signal, (signum,)).start()
        return
    raise KeyboardInterrupt


def install() -> None:
    """SIGINT and SIGTERM call :func:`interrupt`.

    PETSc installs its own handler for them at its initialization (inside ``import
    dolfinx``), which prints "Caught signal number 15" and aborts with MPI_Abort (exit 15
    or 59): ``-no_signal_handler`` in ``PETSC_OPTIONS`` (read by PetscInitialize) leaves
    ours in place (seen on the pip path's PETSc wheel: tests/system/test_faults.py)."""
    options = os.environ.get("PETSC_OPTIONS", "")
    if "-no_signal_handler" not in options.split():
        os.environ["PETSC_OPTIONS"] = f"{options} -no_signal_handler".strip()
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
