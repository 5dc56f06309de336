#!/usr/bin/env bash
# A throw-away single-node Slurm cluster (munged + slurmctld + slurmd) configured in a folder,
# for the cluster test (test/test_app_farm.cpp) and for trying `vbme farm slurm` on one machine.
#
#   scripts/slurm-local.sh start DIR   start it; prints the lines to source (SLURM_CONF, PATH)
#   scripts/slurm-local.sh stop DIR    stop it (only the daemons it started, by their pid files)
#
# Needs Debian's slurm-wlm and munge (install-deps.sh) and root (slurmd starts jobs as their
# user). Exit code 3 with the reason on stderr when the cluster cannot start here.
set -uo pipefail
cmd="${1:-}"; DIR="${2:-}"
[ -n "$cmd" ] && [ -n "$DIR" ] || { sed -n '2,9p' "$0"; exit 2; }
mkdir -p "$DIR"; DIR="$(cd "$DIR" && pwd)"
fail() { echo "slurm-local: $*" >&2; exit 3; }
# munge's socket must fit a Unix socket address (108 bytes): use a short DIR such as /tmp/x
[ "$cmd" != start ] || [ ${#DIR} -le 80 ] || fail "'$DIR' is too long for munge's socket path"

stop() {
  for d in slurmd slurmctld munged; do
    if [ -f "$DIR/$d.pid" ]; then
      pid="$(cat "$DIR/$d.pid" 2>/dev/null || true)"
      [ -n "$pid" ] && kill "$pid" 2>/dev/null || true
    fi
  done
  sleep 1
  for d in slurmd slurmctld munged; do
    if [ -f "$DIR/$d.pid" ]; then
      pid="$(cat "$DIR/$d.pid" 2>/dev/null || true)"
      [ -n "$pid" ] && kill -9 "$pid" 2>/dev/null || true
      rm -f "$DIR/$d.pid"
    fi
  done
}

if [ "$cmd" = stop ]; then stop; exit 0; fi
[ "$cmd" = start ] || { echo "slurm-local: unknown command '$cmd'" >&2; exit 2; }

for p in munged slurmctld slurmd sbatch scontrol; do
  command -v "$p" >/dev/null 2>&1 || [ -x "/usr/sbin/$p" ] ||
    fail "$p is not installed (Debian packages slurm-wlm and munge)"
done
[ "$(id -u)" -eq 0 ] || fail "not root: slurmd must run as root to start jobs"
PATH="/usr/sbin:$PATH"
host="$(hostname -s)"
cpus="$(nproc)"
mem="$(awk '/MemTotal/ {print int($2/1024*0.8)}' /proc/meminfo)"
mkdir -p "$DIR/spool/ctld" "$DIR/spool/d" "$DIR/munge" "$DIR/log"
chmod 700 "$DIR/munge"

# munge: a key of our own and a socket in the folder
[ -f "$DIR/munge/munge.key" ] || dd if=/dev/urandom of="$DIR/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 400 "$DIR/munge/munge.key"
munged --force --key-file="$DIR/munge/munge.key" --socket="$DIR/munge/munge.sock" \
  --pid-file="$DIR/munged.pid" --log-file="$DIR/log/munged.log" \
  --seed-file="$DIR/munge/munge.seed" 2>"$DIR/log/munged.err" ||
  fail "munged did not start: $(tail -n 3 "$DIR/log/munged.err" "$DIR/log/munged.log" 2>/dev/null | tr '\n' ' ')"

port=$(( 20000 + RANDOM % 20000 ))
cat > "$DIR/slurm.conf" <<CONF
ClusterName=vbmetest
SlurmctldHost=$host
SlurmctldPort=$port
SlurmdPort=$(( port + 1 ))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.sock
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$DIR/spool/ctld
SlurmdSpoolDir=$DIR/spool/d
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
MpiDefault=none
SwitchType=switch/none
PlugStackConfig=/dev/null
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=vbme Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
rm -f "$DIR/cgroup.conf"
export SLURM_CONF="$DIR/slurm.conf"
slurmctld -f "$DIR/slurm.conf" 2>"$DIR/log/slurmctld.err" ||
  { stop; fail "slurmctld did not start: $(tail -n 3 "$DIR/log/slurmctld.log" "$DIR/log/slurmctld.err" 2>/dev/null | tr '\n' ' ')"; }
slurmd -f "$DIR/slurm.conf" 2>"$DIR/log/slurmd.err" ||
  { stop; fail "slurmd did not start: $(tail -n 3 "$DIR/log/slurmd.log" "$DIR/log/slurmd.err" 2>/dev/null | tr '\n' ' ')"; }
for i in $(seq 1 40); do
  state="$(scontrol show node "$host" 2>/dev/null | sed -n 's/.*State=\([A-Z+_]*\).*/\1/p' | head -n1)"
  case "$state" in IDLE*|MIXED*|ALLOCATED*) echo "export SLURM_CONF=$DIR/slurm.conf"; exit 0 ;; esac
  sleep 0.5
done
msg="the node did not become idle (state '${state:-unknown}'): $(tail -n 3 "$DIR/log/slurmd.log" "$DIR/log/slurmctld.log" 2>/dev/null | tr '\n' ' ')"
stop
fail "$msg"
