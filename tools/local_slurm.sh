#!/usr/bin/env bash
# A one-node Slurm cluster on this machine (munged, slurmctld, slurmd), for campaign tests and trials.
#
# Usage: tools/local_slurm.sh start|stop|status|env
#   start   writes slurm.conf for this host and starts munged, slurmctld and slurmd (idempotent: running
#           daemons are kept); then `eval "$(tools/local_slurm.sh env)"` points sbatch/squeue at it
#   stop    stops the three daemons this script started (by the pids in their pid files)
#   status  says which daemons run and prints sinfo
#   env     prints export SLURM_CONF=...
# Everything lives in $RAILCOSIM_CACHE/slurm (default ~/.cache/railcosim/slurm): its own munge key and socket,
# configuration, state, logs and pid files; nothing under /etc, /run or /var is written, so a Slurm or munge
# already on the machine is not disturbed. Ports: RAILCOSIM_SLURMCTLD_PORT (default 6917) and
# RAILCOSIM_SLURMD_PORT (6918), away from Slurm's defaults 6817/6818.
# Needs Debian's slurm-wlm and munge (apt-get install slurm-wlm munge). As root the daemons run as root; as
# another user, slurmd runs jobs as that user only.
set -euo pipefail

cache=${RAILCOSIM_CACHE:-$HOME/.cache/railcosim}
dir=$cache/slurm
conf=$dir/slurm.conf
socket=$dir/munge/munge.socket
ctld_port=${RAILCOSIM_SLURMCTLD_PORT:-6917}
slurmd_port=${RAILCOSIM_SLURMD_PORT:-6918}
host=$(hostname -s)

say() { printf '[local-slurm] %s\n' "$*"; }
die() { printf '[local-slurm] ERROR: %s\n' "$*" >&2; exit 1; }

running() {  # running NAME: the daemon recorded in NAME.pid is alive and is that program
  local pid_file=$dir/run/$1.pid pid
  [ -f "$pid_file" ] || return 1
  pid=$(cat "$pid_file" 2>/dev/null) || return 1
  [ -n "$pid" ] && [ -r "/proc/$pid/comm" ] && grep -q "${1%d}" "/proc/$pid/comm"
}

write_conf() {
  local cpus memory user
  cpus=$(nproc --all)
  memory=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)
  user=$(id -un)
  mkdir -p "$dir/state" "$dir/spool" "$dir/log" "$dir/run"
  cat > "$conf.tmp" <<EOF
# Written by tools/local_slurm.sh for $host: one node, every CPU, no cgroups, no accounting.
ClusterName=railcosim-local
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/%n
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
MinJobAge=30
NodeName=$host CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$conf.tmp" "$conf"
}

start_munge() {
  running munged && return
  command -v munged > /dev/null || die "munged is missing: apt-get install munge"
  mkdir -p "$dir/munge"
  chmod 0700 "$dir/munge"
  if [ ! -s "$dir/munge/munge.key" ]; then
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
    chmod 0400 "$dir/munge/munge.key"
  fi
  munged --force --socket="$socket" --key-file="$dir/munge/munge.key" --pid-file="$dir/run/munged.pid" \
         --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed"
  say "munged started (socket $socket)"
}

wait_for() {  # wait_for SECONDS WHAT COMMAND...
  local seconds=$1 what=$2; shift 2
  for _ in $(seq $((seconds * 5))); do "$@" > /dev/null 2>&1 && return 0; sleep 0.2; done
  die "$what did not come up within $seconds s (logs in $dir/log)"
}

start() {
  command -v slurmctld > /dev/null || die "slurmctld is missing: apt-get install slurm-wlm munge"
  write_conf
  start_munge
  export SLURM_CONF=$conf
  if ! running slurmctld; then
    slurmctld -f "$conf"
    say "slurmctld started (port $ctld_port)"
  fi
  wait_for 30 slurmctld scontrol ping
  if ! running slurmd; then
    slurmd -f "$conf"
    say "slurmd started (port $slurmd_port)"
  fi
  wait_for 60 "node $host" bash -c "sinfo --noheader --nodes='$host' --format=%t | grep -qE '^(idle|mix|alloc)'"
  say "ready: partition 'local', node $host; export SLURM_CONF=$conf"
}

stop() {
  local name pid
  for name in slurmd slurmctld munged; do
    if running "$name"; then
      pid=$(cat "$dir/run/$name.pid")
      kill "$pid"
      for _ in $(seq 50); do [ -d "/proc/$pid" ] || break; sleep 0.1; done
      say "$name stopped (pid $pid)"
    fi
  done
}

status() {
  local name state=0
  for name in munged slurmctld slurmd; do
    if running "$name"; then say "$name running (pid $(cat "$dir/run/$name.pid"))"; else say "$name not running"; state=3; fi
  done
  if [ $state -eq 0 ]; then SLURM_CONF=$conf sinfo; fi
  return $state
}

case "${1:-}" in
  start) start ;;
  stop) stop ;;
  status) status ;;
  env) echo "export SLURM_CONF=$conf" ;;
  *) echo "usage: tools/local_slurm.sh start|stop|status|env" >&2; exit 2 ;;
esac
