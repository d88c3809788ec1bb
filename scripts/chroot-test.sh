#!/usr/bin/env bash
# Run this project's set-up and test suite inside a Debian chroot of another release, as a
# new user on that release would: debootstrap (minbase) once, copy the work tree in, then the
# README's own ./scripts/test.sh inside it (serial suite + MPI tests).
#
#   scripts/chroot-test.sh RELEASE [--fresh] [-- PYTEST_ARGS...]
#   scripts/chroot-test.sh RELEASE [--fresh] --run 'COMMAND'   # set up, then COMMAND instead
#   scripts/chroot-test.sh RELEASE --pip [...]                 # the pip path (no apt FEniCSx)
#
# RELEASE is a Debian suite: trixie (DOLFINx 0.9), sid (DOLFINx 0.11), bookworm (0.5).
# The chroot lives in $DPCOLLAPSE_CHROOT_DIR/RELEASE (default /var/tmp/dpcollapse-chroot);
# it is reused when it was completed before, rebuilt from scratch with --fresh.
# --pip: a separate chroot RELEASE-pip whose only Debian packages beyond minbase are a Python
# with its headers, a C compiler (FFCx's JIT) and gmsh's X11/GLU libraries, no FEniCSx, MPI
# or PETSc (checked); set-up is `./scripts/setup.sh --pip`
# (DOLFINx 0.11 and MPICH from PyPI wheels; needs Python >= 3.12, i.e. trixie or later),
# and the MPI tests run under the wheel's MPICH (the venv's bin/ first on PATH).
# Needs root, debootstrap (installed if missing) and about 5.5 GB of disk per release.
# Every exit path unmounts what it mounted.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

release="${1:-}"
[ -n "$release" ] || { echo "usage: scripts/chroot-test.sh RELEASE [--fresh] [-- PYTEST_ARGS...]" >&2; exit 2; }
shift
fresh=0
pip=0
command=""
while [ $# -gt 0 ]; do
  case "$1" in
    --fresh) fresh=1; shift ;;
    --pip) pip=1; shift ;;
    --run) command="${2:?--run needs a command}"; shift 2 ;;
    --) shift; break ;;
    *) break ;;
  esac
done
[ "$(id -u)" -eq 0 ] || { echo "chroot-test: needs root (debootstrap, mount, chroot)" >&2; exit 2; }

mirror="${DPCOLLAPSE_DEBIAN_MIRROR:-http://deb.debian.org/debian}"
base="${DPCOLLAPSE_CHROOT_DIR:-/var/tmp/dpcollapse-chroot}"
name="$release"
[ "$pip" -eq 1 ] && name="$release-pip"
target="$base/$name"
marker="$target/.dpcollapse-bootstrapped"
mkdir -p "$base"
# One run per chroot at a time: a second one would replace the work tree and unmount the
# file systems under the first.
exec 9>"$base/$name.lock"
flock -n 9 || { echo "chroot-test: another run on $name is in progress ($base/$name.lock)" >&2; exit 2; }

mounts=()
cleanup() {
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount -l "${mounts[$i]}" 2>/dev/null || true
  done
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# A chroot from an earlier run that died mid-way may still have mounts: drop them first.
for m in proc sys dev/shm dev/pts; do
  mountpoint -q "$target/$m" 2>/dev/null && umount -l "$target/$m" || true
done

if [ "$fresh" -eq 1 ] || [ ! -f "$marker" ]; then
  command -v debootstrap >/dev/null || {
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
  }
  rm -rf "$target"
  mkdir -p "$target"
  echo "chroot-test: debootstrap --variant=minbase $release $target"
  t0=$(date +%s)
  debootstrap --variant=minbase "$release" "$target" "$mirror" >"$base/debootstrap-$name.log" 2>&1 || {
    echo "chroot-test: debootstrap failed, see $base/debootstrap-$name.log" >&2; exit 1; }
  echo "chroot-test: debootstrap took $(( $(date +%s) - t0 )) s"
  # A mirror snapshot of sid can carry an expired Release file.
  echo 'Acquire::Check-Valid-Until "false";' > "$target/etc/apt/apt.conf.d/99dpcollapse-snapshot"
  touch "$marker"
fi

# Reach the package registries the way the host does: its extra CA certificates (appended to
# the chroot's bundle once ca-certificates is in), its pip configuration and PIP_* variables.
mkdir -p "$target/usr/local/share/ca-certificates" "$target/etc/ssl/certs"
cp -f /usr/local/share/ca-certificates/*.crt "$target/usr/local/share/ca-certificates/" 2>/dev/null || true
[ -f /etc/ssl/certs/ca-certificates.crt ] && cp -f /etc/ssl/certs/ca-certificates.crt "$target/etc/ssl/certs/ca-certificates.crt"
[ -f /etc/pip.conf ] && cp -f /etc/pip.conf "$target/etc/pip.conf"
if [ -d /etc/xdg/pip ]; then mkdir -p "$target/etc/xdg/pip" && cp -rf /etc/xdg/pip/. "$target/etc/xdg/pip/"; fi
cp -f /etc/resolv.conf "$target/etc/resolv.conf" 2>/dev/null || true

mount_one() {  # mount_one TYPE SOURCE DEST [OPTIONS]
  mkdir -p "$3"
  mount -t "$1" ${4:+-o "$4"} "$2" "$3"
  mounts+=("$3")
}
mount_one proc proc "$target/proc"
mount_one tmpfs tmpfs "$target/dev/shm" "mode=1777"
mount_one devpts devpts "$target/dev/pts" "newinstance,ptmxmode=0666"
mkdir -p "$target/sys"
mount --bind /sys "$target/sys" && mounts+=("$target/sys") && mount -o remount,bind,ro "$target/sys"

# The work tree (tracked and untracked, not ignored) replaces the previous copy; the chroot's
# own .venv and JIT cache stay between runs so that a second run is quick.
dest="$target/work/dpcollapse"
mkdir -p "$dest"
find "$dest" -mindepth 1 -maxdepth 1 ! -name .venv ! -name .cache -exec rm -rf {} +
(cd "$root" && git ls-files -z -co --exclude-standard | tar --null -T - -cf -) | tar -xf - -C "$dest"
if [ -d "$root/../shared" ]; then
  rm -rf "$target/work/shared" && cp -r "$root/../shared" "$target/work/shared"
fi

pip_env=()
while IFS='=' read -r k v; do
  # a find-links folder of the host that the chroot does not have: pip would warn on every lookup
  [ "$k" = PIP_FIND_LINKS ] && [ ! -e "$target$v" ] && continue
  pip_env+=("$k=$v")
done < <(env | grep -E '^PIP_' || true)

setup='./scripts/setup.sh'
prelude=''
if [ "$pip" -eq 1 ]; then
  # The user's side of the pip path: a Python >= 3.12 with its headers, venv and a C
  # compiler (FFCx's JIT), the X11/GLU libraries that gmsh's wheel links; nothing of
  # FEniCSx, MPI or PETSc from Debian (checked).
  read -r -d '' prelude <<'EOS' || true
user_packages="python3-venv python3-dev gcc libgl1 libglu1-mesa libxcursor1 libxft2 libxinerama1"
n=$(dpkg-query -W -f='${Status}\n' $user_packages 2>/dev/null | grep -c 'install ok installed' || true)
if [ "$n" -ne 8 ]; then
  echo "chroot-test: installing $user_packages (Debian)"
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $user_packages >/dev/null
fi
if dpkg-query -W -f='${Status}\n' python3-dolfinx python3-petsc4py python3-mpi4py 2>/dev/null | grep -q 'install ok installed'; then
  echo "chroot-test: this chroot has Debian's FEniCSx: not a pip-only one" >&2; exit 2
fi
export DPCOLLAPSE_SETUP=pip PATH=/work/dpcollapse/.venv/bin:$PATH
EOS
  prelude+=$'\n'
  setup='./scripts/setup.sh --pip'
fi
if [ -n "$command" ]; then
  inner="$prelude"$setup' && export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_rmaps_base_oversubscribe=1 XDG_CACHE_HOME=/work/dpcollapse/.cache && '"$command"
  echo "chroot-test: $name: $command"
else
  inner="$prelude"'./scripts/test.sh "$@"'
  echo "chroot-test: $name: ./scripts/test.sh $*"
fi
chroot "$target" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
  LANG=C.UTF-8 CI="${CI:-}" "${pip_env[@]}" \
  /bin/bash -c "cd /work/dpcollapse && $inner" chroot-test "$@"
