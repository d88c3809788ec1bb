#!/usr/bin/env bash
# Install what is missing, idempotently, and fast when nothing is:
#   1. Debian's FEniCSx 0.5.2 stack, MPI, MUMPS, OpenBLAS, ParaView (apt);
#   2. a .venv at the repository root made from /usr/bin/python3 --system-site-packages;
#   3. this package, editable, with its test extras (PyPI), never upgrading Debian's numpy.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

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
