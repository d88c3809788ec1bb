#!/usr/bin/env bash
# Install what is missing, idempotently, and fast when nothing is. Two paths:
#
#   ./scripts/setup.sh          the apt path (default; Debian/Ubuntu, root or sudo):
#     1. Debian's FEniCSx stack, MPI, MUMPS, OpenBLAS, ParaView (apt);
#     2. a .venv at the repository root made from /usr/bin/python3 --system-site-packages;
#     3. this package, editable, with its test extras (PyPI), never upgrading Debian's numpy.
#   ./scripts/setup.sh --pip    the pip path (any Linux x86_64 with glibc >= 2.34, no root):
#     a .venv from ${PYTHON:-python3} (>= 3.12) with DOLFINx 0.11, PETSc, MPICH, gmsh and
#     h5py from PyPI wheels (the `wheels` extra) and this package, editable. FFCx's JIT
#     needs a C compiler and the Python headers; gmsh's wheel needs the X11/GLU libraries.
#
# A .venv made by --pip is kept on the pip path by later plain calls (scripts/test.sh);
# DPCOLLAPSE_SETUP=pip does the same as --pip.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

mode="${DPCOLLAPSE_SETUP:-}"
for arg in "$@"; do
  case "$arg" in
    --pip) mode=pip ;;
    --apt) mode=apt ;;
    *) echo "setup: unknown option $arg (allowed: --pip, --apt)" >&2; exit 2 ;;
  esac
done
[ -z "$mode" ] && [ -f .venv/.dpcollapse-pip ] && mode=pip
case "${mode:-apt}" in
  pip) exec "$root/scripts/setup-pip.sh" ;;
  apt) ;;
  *) echo "setup: DPCOLLAPSE_SETUP=$mode (allowed: pip, apt)" >&2; exit 2 ;;
esac
if [ -f .venv/.dpcollapse-pip ]; then
  echo "setup: .venv was made by --pip; remove it (rm -rf .venv) to take the apt path" >&2; exit 2
fi

apt_packages=(
  python3-dolfinx python3-dolfinx-mpc python3-gmsh python3-h5py python3-petsc4py
  python3-mpi4py python3-yaml python3-matplotlib python3-scipy python3-venv
  openmpi-bin libopenblas0-pthread paraview
)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  sudo_cmd=""; [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${missing[@]}" >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv from /usr/bin/python3 --system-site-packages"
  /usr/bin/python3 -m venv --system-site-packages .venv
fi

# Reinstall only when pyproject.toml changed since the last successful install.
stamp=.venv/.dpcollapse-installed
want="$(sha256sum pyproject.toml | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ] || [ ! -x .venv/bin/dpcollapse ]; then
  echo "setup: installing dpcollapse (editable) into .venv"
  # Pin Debian's numpy: dolfinx, petsc4py and h5py are compiled against it.
  numpy_version="$(/usr/bin/python3 -c 'import numpy; print(numpy.__version__)')"
  echo "numpy==${numpy_version}" > .venv/constraints.txt
  .venv/bin/python -m pip install -q --disable-pip-version-check \
      -c .venv/constraints.txt -e ".[test]"
  echo "$want" > "$stamp"
fi
