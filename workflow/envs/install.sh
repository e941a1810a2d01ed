#!/usr/bin/env bash
# Idempotent installation of everything the project needs:
#   1. the few Debian packages of apt-packages.txt that PyPI cannot give (only the missing ones);
#   2. a virtual environment .venv on a Python >= 3.12, holding every pin of requirements.txt
#      (and constraints.txt) from PyPI: DOLFINx 0.11 with PETSc, SLEPc, MUMPS and MPICH included.
#      No system site packages: the venv is all a compute node needs.
#   3. the project itself into that venv (editable), with its command-line entry points.
# Re-running it is cheap: it only checks, and installs what is missing or changed.
# PYTHON=/path/to/python3.12 picks the interpreter; otherwise the first Python >= 3.12 found.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/.venv"

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

# The interpreter: a Python >= 3.12 (the DOLFINx wheel's floor).
recent() { "$1" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 12) else 1)' 2>/dev/null; }
venv_ok() {   # an existing .venv on a recent Python, not made with the system's site packages
  [ -x "$venv/bin/python" ] && recent "$venv/bin/python" &&
    ! grep -qi '^include-system-site-packages *= *true' "$venv/pyvenv.cfg" 2>/dev/null
}
if ! venv_ok; then
  python=""
  # 3.12 first: the version the pins of requirements.txt and constraints.txt were verified on
  for cand in "${PYTHON:-}" python3.12 \
              $(ls -d "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.12*/bin/python3 2>/dev/null | sort -rV) \
              python3.13 python3.14 \
              $(ls -d "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.1[3-9]*/bin/python3 2>/dev/null | sort -rV) \
              python3 /usr/bin/python3; do
    [ -n "$cand" ] || continue
    path="$(command -v "$cand" 2>/dev/null || true)"
    if [ -n "$path" ] && recent "$path" && "$path" -c 'import venv, ensurepip' 2>/dev/null; then
      python="$path"; break
    fi
  done
  if [ -z "$python" ]; then
    echo "install: no Python >= 3.12 with venv found: install one (e.g. 'pyenv install 3.12' or Debian's python3.12-venv) or set PYTHON=/path/to/python3.12" >&2
    exit 1
  fi
  [ -e "$venv" ] && { echo "install: replacing $venv (older Python or system site packages)"; rm -rf "$venv"; }
  echo "install: creating $venv with $python ($("$python" -c 'import sys; print(sys.version.split()[0])'))"
  "$python" -m venv "$venv"
fi

stamp="$venv/.requirements.sha256"
want="$(cat "$here/requirements.txt" "$here/cluster-requirements.txt" "$here/constraints.txt" \
        "$root/pyproject.toml" | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "install: pip installing workflow/envs/requirements.txt into $venv (a few minutes the first time)"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    -c "$here/constraints.txt" -r "$here/requirements.txt"
  # The Slurm executor apart, in $venv/cluster (cluster-requirements.txt says why); a venv made
  # before it moved there loses its copy in site-packages
  "$venv/bin/python" -m pip uninstall --quiet --disable-pip-version-check -y \
    snakemake-executor-plugin-slurm snakemake-executor-plugin-slurm-jobstep >/dev/null 2>&1 || true
  rm -rf "$venv/cluster"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --target "$venv/cluster" \
    -c "$here/constraints.txt" -r "$here/cluster-requirements.txt"
  # the project itself, editable: its packages and entry points; its dependencies are the pins above
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation \
    -e "$root"
  echo "$want" > "$stamp"
fi
"$venv/bin/python" -c "import dolfinx_solver, dolfinx, slepc4py, gmsh, snakemake, numba, typst" || {
  echo "install: the environment is incomplete (dolfinx/slepc4py/gmsh/snakemake/numba/typst not importable)" >&2; exit 1; }
PYTHONPATH="$venv/cluster" "$venv/bin/python" -c "import snakemake_executor_plugin_slurm, snakemake_executor_plugin_slurm_jobstep" || {
  echo "install: the Slurm executor in $venv/cluster is not importable" >&2; exit 1; }
# The dynamics kernels compiled ahead of time for this machine (gimbal_reduction.solver.dynamics.
# kernels.extension): a fresh process's first simulation then loads no JIT code.  Built once (the
# workflow's warm-up with a recording-only JIT, GIMBAL_KERNELS=build, then the extension: ~50-65
# CPU-s), again only when a kernel, Numba or the CPU changed; if it cannot be built (no C compiler)
# the kernels stay Numba's JIT.
if ! command -v cc >/dev/null 2>&1; then
  echo "install: no C compiler (cc): the dynamics kernels stay Numba's JIT" >&2
elif ! GIMBAL_KERNELS=build OMP_NUM_THREADS=1 "$venv/bin/python" -m gimbal_reduction.solver.dynamics.warmup --extension \
       --scenes "$root/config/scenes/thesis.yaml" "$root/config/scenes/damped.yaml"; then
  echo "install: the kernels' extension was not built: the dynamics kernels stay Numba's JIT" >&2
fi
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
echo "install: environment ready ($venv, $("$venv/bin/python" -c 'import sys; print("Python", sys.version.split()[0])'))"
