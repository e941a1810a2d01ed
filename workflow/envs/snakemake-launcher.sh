#!/bin/sh
# snakemake: runs the Snakemake of the project you are in (installed by workflow/envs/install.sh).
# It looks for a project (a Snakefile beside a .venv made by `make install`) in the working
# directory and above, and runs that project's `.venv/bin/python -m snakemake` with your arguments,
# so the stages run with the interpreter that has DOLFINx, Numba and Typst. Outside a project it
# hands over to the next `snakemake` on PATH, if any.
# gimbal-reduction-snakemake-launcher (marker: install.sh replaces only a file carrying it)
dir=$(pwd -P)
while :; do
  if [ -f "$dir/Snakefile" ] && [ -x "$dir/.venv/bin/python" ]; then
    # a cluster run (an argument names slurm: --executor slurm, --profile workflow/profiles/slurm)
    # sees the Slurm executor, installed apart in .venv/cluster (cluster-requirements.txt)
    case " $* " in
      *slurm*) PYTHONPATH="$dir/.venv/cluster${PYTHONPATH:+:$PYTHONPATH}"; export PYTHONPATH ;;
    esac
    exec "$dir/.venv/bin/python" -m snakemake "$@"
  fi
  [ "$dir" = / ] && break
  dir=$(dirname "$dir")
done
self=$(readlink -f "$0")
IFS=:
for d in $PATH; do
  if [ -x "$d/snakemake" ] && [ "$(readlink -f "$d/snakemake")" != "$self" ]; then
    exec "$d/snakemake" "$@"
  fi
done
echo "snakemake: no project (Snakefile and .venv) in $(pwd) or above: run 'make install' in the project and call snakemake from there, or '. .venv/bin/activate'" >&2
exit 127
