#!/usr/bin/env bash
# A real Slurm cluster of one node on localhost, to prove the workflow's cluster path:
#   1. installs Slurm, munge, slurmdbd and MariaDB from Debian (apt) if missing (the Slurm executor
#      plugin asks `sacct` for the jobs' states, which needs Slurm's accounting database);
#   2. writes a single-node slurm.conf in a temporary folder, listening on 127.0.0.1 only, with
#      MpiDefault=pmi2 (the MPICH of PyPI's DOLFINx wheel starts under srun with PMI-2 and refuses
#      PMIx; Debian's Slurm 22.05 has mpi_pmix, mpi_pmi2, mpi_none: `srun --mpi=list`);
#   3. starts munged, a private MariaDB (its data in the temporary folder, on 127.0.0.1), slurmdbd,
#      slurmctld and slurmd;
#   4. runs the mesh and the modes of every body (modes_body under srun with 2 MPI ranks) and a few
#      simulations through `--executor slurm --profile workflow/profiles/slurm` in a temporary copy
#      of the test configuration (.test), and the same targets locally
#      (`--profile workflow/profiles/local`) in another copy;
#   5. compares the outputs (workflow/cluster/compare.py) and stops the daemons (also on failure).
# Nothing talks to another host. Run as root (apt, daemons):  make cluster-test
# KEEP=1 keeps the temporary folder (logs, slurm.conf); TARGETS=... overrides the targets.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
py="$root/.venv/bin/python"
[ "$(id -u)" -eq 0 ] || { echo "slurm_localhost: run as root (apt-get, daemons)" >&2; exit 1; }

# ---- 1. packages (Debian bookworm: Slurm 22.05, munge 0.5.15)
wanted=(slurmd slurmctld slurm-client munge slurmdbd mariadb-server)
missing=()
for pkg in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  echo "slurm_localhost: apt-get install ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# the Slurm executor is installed apart (workflow/envs/cluster-requirements.txt): on the path of
# this run and, through sbatch's exported environment, of its jobs
export PYTHONPATH="$root/.venv/cluster${PYTHONPATH:+:$PYTHONPATH}"
"$py" -c "import snakemake_executor_plugin_slurm" 2>/dev/null || {
  echo "slurm_localhost: the Slurm executor plugin is missing: make install" >&2; exit 1; }

# ---- 2. configuration
tmp="$(mktemp -d /tmp/gimbal-slurm.XXXXXX)"
conf="$tmp/etc/slurm.conf"
mkdir -p "$tmp/etc" "$tmp/state" "$tmp/spool" "$tmp/log" "$tmp/run" "$tmp/mysql"
node="$(hostname -s)"
cpus="$(nproc)"
# the node's memory for jobs: all but 1 GB, in MB
mem_mb="$(awk '/MemTotal/ {printf "%d", $2 / 1024 - 1024}' /proc/meminfo)"
mpi_default=pmi2
cat > "$conf" <<EOF
# single-node Slurm on localhost (workflow/cluster/slurm_localhost.sh), ports off the defaults
ClusterName=gimbal-local
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/run/slurmctld.pid
SlurmdPidFile=$tmp/run/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=$mpi_default
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=5
# accounting (sacct: the executor plugin's job states, the jobs' elapsed time and MaxRSS)
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=127.0.0.1
AccountingStoragePort=16819
JobCompType=jobcomp/none
# keep the plugin's --comment (the rule and its wildcards) for sacct
AccountingStoreFlags=job_comment
MinJobAge=300
ReturnToService=2
SchedulerType=sched/backfill
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
dbpass="$(head -c 12 /dev/urandom | od -An -tx1 | tr -d ' \n')"
cat > "$tmp/etc/slurmdbd.conf" <<EOF
AuthType=auth/munge
DbdHost=localhost
DbdAddr=127.0.0.1
DbdPort=16819
SlurmUser=root
PidFile=$tmp/run/slurmdbd.pid
LogFile=$tmp/log/slurmdbd.log
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=13306
StorageUser=slurm
StoragePass=$dbpass
StorageLoc=slurm_acct_db
EOF
chmod 600 "$tmp/etc/slurmdbd.conf"
export SLURM_CONF="$conf"
# The clients inside a job find it without SLURM_CONF (the jobstep plugin clears every SLURM_*
# variable before its srun): a link at Slurm's default path, made only where none exists (a machine
# with a Slurm of its own is refused) and removed when the test ends.
default_conf=/etc/slurm/slurm.conf
if [ -e "$default_conf" ] || [ -L "$default_conf" ]; then
  echo "slurm_localhost: $default_conf exists: this machine has a Slurm of its own; not touched" >&2; exit 1
fi
export USER="${USER:-$(id -un)}"   # the plugin reads it

# ---- 3. daemons (stopped on exit, whatever happens)
mkdir -p /run/munge && chown munge:munge /run/munge && chmod 0755 /run/munge
[ -s /etc/munge/munge.key ] || { mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null || \
  dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null; \
  chown munge:munge /etc/munge/munge.key; chmod 0400 /etc/munge/munge.key; }
munge_pid=""
if ! pgrep -x munged >/dev/null; then
  runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/gimbal-munged.pid
  sleep 1
  munge_pid="$(cat /run/munge/gimbal-munged.pid)"
fi
stop() {
  status=$?
  echo "slurm_localhost: stopping the daemons"
  for f in "$tmp/run/slurmd.pid" "$tmp/run/slurmctld.pid" "$tmp/run/slurmdbd.pid" "$tmp/run/mariadb.pid"; do
    [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
  done
  [ -n "$munge_pid" ] && kill "$munge_pid" 2>/dev/null || true
  [ "$(readlink "$default_conf" 2>/dev/null)" = "$conf" ] && rm -f "$default_conf"
  sleep 1
  if [ "${KEEP:-0}" = 1 ] || [ "$status" -ne 0 ]; then
    echo "slurm_localhost: kept $tmp (logs, slurm.conf)"
  else
    rm -rf "$tmp"
  fi
  exit "$status"
}
trap stop EXIT
mkdir -p /etc/slurm
ln -s "$conf" "$default_conf"
# the accounting database: a private MariaDB on 127.0.0.1:13306, then slurmdbd on 127.0.0.1:16819
mariadb-install-db --datadir="$tmp/mysql" --user=root --auth-root-authentication-method=socket \
  > "$tmp/log/mariadb-install.log" 2>&1
/usr/sbin/mariadbd --user=root --datadir="$tmp/mysql" --socket="$tmp/run/mysql.sock" \
  --pid-file="$tmp/run/mariadb.pid" --bind-address=127.0.0.1 --port=13306 --skip-name-resolve \
  --log-error="$tmp/log/mariadb.log" &
for _ in $(seq 60); do mariadb --socket="$tmp/run/mysql.sock" -u root -e "select 1" >/dev/null 2>&1 && break; sleep 1; done
mariadb --socket="$tmp/run/mysql.sock" -u root -e "CREATE USER 'slurm'@'127.0.0.1' IDENTIFIED BY '$dbpass';
  GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1'; FLUSH PRIVILEGES;"
/usr/sbin/slurmdbd
for _ in $(seq 60); do sacctmgr -n list cluster >/dev/null 2>&1 && break; sleep 1; done
sacctmgr -i add cluster gimbal-local >/dev/null
/usr/sbin/slurmctld -f "$conf"
/usr/sbin/slurmd -f "$conf" -N "$node"
for _ in $(seq 60); do
  sinfo -h -o %T 2>/dev/null | grep -qx idle && break
  sleep 1
done
sinfo -h -o "%P %D %c %m %T" | sed 's/^/slurm_localhost: partition nodes cpus mem state: /'
sinfo -h -o %T | grep -qx idle || { echo "slurm_localhost: the node did not come up" >&2; exit 1; }
echo "slurm_localhost: srun --mpi=list: $(srun --mpi=list 2>&1 | tr '\n' ' ')"

# ---- 4. the runs: the same targets on the cluster and locally, each in a copy of .test
targets=(${TARGETS:-mesh modes results/sim/short/freq-4.h5 results/sim/short/xmx-4.h5 results/sim/short/static-2.h5})
for where in cluster local; do
  rm -rf "$tmp/$where"
  cp -r "$root/.test" "$tmp/$where"
done
cd "$root"
start=$(date +%s)
"$py" -m snakemake --snakefile "$root/Snakefile" --directory "$tmp/cluster" --profile workflow/profiles/slurm \
  --slurm-no-account --slurm-logdir "$tmp/cluster/logs/slurm" --slurm-keep-successful-logs "${targets[@]}" 2>&1 | tee "$tmp/cluster.log"
cluster_s=$(( $(date +%s) - start ))
start=$(date +%s)
"$py" -m snakemake --snakefile "$root/Snakefile" --directory "$tmp/local" --profile workflow/profiles/local \
  "${targets[@]}" > "$tmp/local.log" 2>&1
local_s=$(( $(date +%s) - start ))
echo "slurm_localhost: cluster run ${cluster_s} s, local run ${local_s} s"
echo "slurm_localhost: the cluster's jobs (sacct: id, rule and wildcards, state, elapsed, requested memory, MaxRSS):"
sacct -a -n -P --starttime "$(date -d '-1 day' +%Y-%m-%dT%H:%M)" -o JobID,Comment%60,State,Elapsed,ReqMem,MaxRSS \
  | sed 's/^/  /' | tee "$tmp/sacct.txt"

# ---- 5. the outputs agree
"$py" "$here/compare.py" "$tmp/cluster" "$tmp/local" "${targets[@]}"
# the cluster's modal stage ran on the profile's two MPI ranks (each body file records its ranks)
"$py" - "$tmp/cluster/results/modes" <<'PYEOF'
import glob, sys
import h5py
ranks = {p: int(h5py.File(p, "r").attrs["mpi_ranks"]) for p in sorted(glob.glob(f"{sys.argv[1]}/body*.h5"))}
print(f"slurm_localhost: MPI ranks of the cluster's modal stage: {ranks}")
sys.exit(0 if ranks and set(ranks.values()) == {2} else 1)
PYEOF
