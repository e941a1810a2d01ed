#!/usr/bin/env bash
# Idempotent installation of everything the project needs on Debian bookworm:
#   1. the Debian packages in apt-packages.txt (only the missing ones are installed);
#   2. a virtual environment .venv made from /usr/bin/python3 with the system
#      site packages (DOLFINx, PETSc, SLEPc, gmsh, snakemake come from Debian),
#      holding the pinned PyPI-only packages of requirements.txt.
# Re-running it is cheap: it only checks, and installs what is missing or changed.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"

mapfile -t wanted < <(grep -v '^\s*#' "$here/apt-packages.txt" | sed '/^\s*$/d')
missing=()
for pkg in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "install: apt packages missing: ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

venv="$root/.venv"
if [ ! -x "$venv/bin/python" ]; then
  echo "install: creating $venv (system site packages)"
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi
stamp="$venv/.requirements.sha256"
want="$(cat "$here/requirements.txt" "$here/constraints.txt" | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  if grep -qv '^\s*\(#.*\)\?$' "$here/requirements.txt"; then
    echo "install: pip installing workflow/envs/requirements.txt"
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -c "$here/constraints.txt" -r "$here/requirements.txt"
  fi
  echo "$want" > "$stamp"
fi
"$venv/bin/python" -c "import dolfinx, slepc4py, gmsh, snakemake" || {
  echo "install: the environment is incomplete (dolfinx/slepc4py/gmsh/snakemake not importable)" >&2; exit 1; }
"$venv/bin/python" -c "import numpy, sys; sys.exit(0 if numpy.__file__.startswith('/usr/lib/python3/') else 1)" || {
  echo "install: .venv shadows Debian's numpy (DOLFINx needs it): check workflow/envs/constraints.txt" >&2; exit 1; }
# The literal `snakemake` command (README): a small launcher in $SNAKEMAKE_BINDIR (default
# /usr/local/bin, on PATH) that runs the .venv's Snakemake of the project in the working directory
# or above (workflow/envs/snakemake-launcher.sh). It replaces no other `snakemake` (only a file
# carrying its marker); without write access it is skipped, and `. .venv/bin/activate` does the same.
bindir="${SNAKEMAKE_BINDIR:-/usr/local/bin}"
launcher="$bindir/snakemake"
marker="gimbal-reduction-snakemake-launcher"
if [ -e "$launcher" ] && ! grep -q "$marker" "$launcher" 2>/dev/null; then
  echo "install: $launcher exists and is not ours: left alone (use '. .venv/bin/activate' before snakemake)"
elif ! cmp -s "$here/snakemake-launcher.sh" "$launcher" 2>/dev/null; then
  if [ -d "$bindir" ] && [ -w "$bindir" ]; then
    install -m 0755 "$here/snakemake-launcher.sh" "$launcher"
    echo "install: $launcher runs the project's .venv Snakemake"
  else
    echo "install: $bindir not writable: no snakemake launcher (use '. .venv/bin/activate' before snakemake)"
  fi
fi
echo "install: environment ready ($venv)"
