#!/usr/bin/env bash
# Set up what is missing, then run the test suite: serial, then the MPI tests on 2 ranks.
# Extra arguments go to both pytest runs (e.g. -k config).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
./scripts/setup.sh

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
# Open MPI 5 (Debian 13+) reads oversubscription from PRRTE's variable instead
export PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
# JIT cache inside the checkout, so a fresh CI clone compiles once and reuses it.
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$root/.cache}"

echo "== serial tests"
.venv/bin/python -m pytest -q "$@"
echo "== MPI tests (mpirun -n 2)"
mpirun -n 2 .venv/bin/python -m pytest -q -m mpi -p no:cacheprovider --color=no "$@"
