#!/usr/bin/env bash
# Set up what is missing, then run the test suite: serial (spread over the cores by
# pytest-xdist), then the MPI tests on 2 ranks. Both suites always run; one summary line
# each at the end; the exit status is non-zero if either failed.
# Extra arguments go to both pytest runs (e.g. -k config). Tests marked `science` (a study's
# measurement, minutes long) are left out: `.venv/bin/python -m pytest -m science` runs them.
#   DPCOLLAPSE_TEST_JOBS  serial workers (default: auto = one per core; 0 = no xdist)
#   DPCOLLAPSE_MPIEXEC    MPI launcher (default: the pip path's .venv/bin/mpiexec where it
#                         exists — the mpich wheel's —, else mpirun)
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
./scripts/setup.sh || exit $?

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
# Open MPI 5 (Debian 13+) reads oversubscription from PRRTE's variable instead
export PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
# JIT cache inside the checkout, so a fresh CI clone compiles once and reuses it. FFCx creates
# each module's C file exclusively and the other workers wait for it: safe under xdist.
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$root/.cache}"

logs="$(mktemp -d)"
trap 'rm -rf "$logs"' EXIT
jobs="${DPCOLLAPSE_TEST_JOBS:-auto}"
xdist=()
[ "$jobs" != "0" ] && xdist=(-n "$jobs" --dist worksteal)

# The last line pytest prints ("N passed, M skipped in S s"), or a note when there is none.
# Under mpirun the two ranks' closing lines can arrive glued on one line (CI's Open MPI 5):
# keep the text up to the first "in S s".
closing() { grep -aE '^=*[ ]*[0-9]+ (passed|failed|error|skipped|deselected)|no tests ran' "$1" \
              | tail -1 | sed -E 's/^=+ //; s/ =+$//; s/( in [0-9.]+s( \([0-9:]+\))?).*/\1/'; }
# pytest's exit 5 is "no test selected" (a -k or -m that matched nothing): not a failure.
ok() { [ "$1" -eq 0 ] || [ "$1" -eq 5 ]; }

echo "== serial tests"
start=$SECONDS
.venv/bin/python -m pytest -q "${xdist[@]}" -m "not science" "$@" 2>&1 | tee "$logs/serial"
serial=${PIPESTATUS[0]}
serial_time=$((SECONDS - start))

mpiexec=mpirun
[ -x .venv/bin/mpiexec ] && mpiexec=.venv/bin/mpiexec
mpiexec="${DPCOLLAPSE_MPIEXEC:-$mpiexec}"
echo "== MPI tests ($mpiexec -n 2)"
start=$SECONDS
"$mpiexec" -n 2 .venv/bin/python -m pytest -q -m mpi -p no:cacheprovider \
    --color=no "$@" 2>&1 | tee "$logs/mpi"
mpi=${PIPESTATUS[0]}
mpi_time=$((SECONDS - start))

echo "== summary"
echo "serial suite: $(closing "$logs/serial") (exit $serial, ${serial_time} s)"
echo "MPI suite (2 ranks): $(closing "$logs/mpi") (exit $mpi, ${mpi_time} s)"
count() { closing "$1" | grep -oE "[0-9]+ $2" | head -1 | grep -oE '^[0-9]+' || echo 0; }
passed=$(( $(count "$logs/serial" passed) + $(count "$logs/mpi" passed) ))
failed=$(( $(count "$logs/serial" failed) + $(count "$logs/mpi" failed) \
           + $(count "$logs/serial" error) + $(count "$logs/mpi" error) ))
# a suite that died before its closing line still counts as a failure
{ ok "$serial" && ok "$mpi"; } || [ "$failed" -gt 0 ] || failed=1
echo "total: $passed passed, $failed failed"
ok "$serial" && ok "$mpi" && exit 0
exit 1
