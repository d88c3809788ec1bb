#!/usr/bin/env bash
# Time configs/rigid.yaml with two commits, interleaved; prints the new/old ratio.
# Usage: studies/benchmarks/compare_speed.sh OLD_REV NEW_REV [--rounds N] [--set KEY=VALUE ...]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
python="${PYTHON:-$root/.venv/bin/python}"
[ -x "$python" ] || python="$(git -C "$root" worktree list --porcelain | awk '/^worktree /{print $2; exit}')/.venv/bin/python"
export XDG_CACHE_HOME="${XDG_CACHE_HOME:-$root/.cache}"
exec "$python" "$root/studies/benchmarks/compare_speed.py" --python "$python" "$@"
