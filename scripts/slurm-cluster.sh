#!/usr/bin/env bash
# A one-node Slurm cluster on localhost, for the Slurm executor's tests
# (tests/it/slurm.rs) and for trying `--executor slurm` by hand:
#   scripts/slurm-cluster.sh up      # install if missing (Debian: apt-get), start munged, slurmctld, slurmd
#   scripts/slurm-cluster.sh down    # stop the daemons this script started
#   scripts/slurm-cluster.sh status
# Needs root (the daemons run as root, munged as munge). No systemd: the daemons are
# started directly. State, spool and logs live under $PP_SLURM_DIR (default
# /tmp/pp-slurm); the configuration is written to /etc/slurm/slurm.conf, where the
# client commands (sbatch, squeue, scancel) look for it.
set -euo pipefail

DIR="${PP_SLURM_DIR:-/tmp/pp-slurm}"
CONF=/etc/slurm/slurm.conf
HOST="$(hostname -s)"

die() { echo "slurm-cluster: $*" >&2; exit 1; }

install_if_missing() {
  if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
     && command -v sbatch >/dev/null && command -v munged >/dev/null; then
    return
  fi
  [ "$(id -u)" -eq 0 ] || die "Slurm is not installed and installing it needs root"
  export DEBIAN_FRONTEND=noninteractive
  apt-get install -y slurmd slurmctld slurm-client munge >/dev/null 2>&1 \
    || { apt-get update >/dev/null 2>&1 && apt-get install -y slurmd slurmctld slurm-client munge >/dev/null 2>&1; } \
    || die "apt-get install slurmd slurmctld slurm-client munge failed"
}

# The PID in a pid file, if that process runs.
alive() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

start_munge() {
  mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
  if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
  chmod 0700 /etc/munge /var/lib/munge /var/log/munge
  chmod 0755 /run/munge
  chmod 0400 /etc/munge/munge.key
  if ! alive /run/munge/munged.pid; then
    # runuser is in util-linux (always there); su would need a login shell for munge.
    runuser -u munge -- /usr/sbin/munged || die "munged did not start"
  fi
  for _ in $(seq 50); do munge -n >/dev/null 2>&1 && return; sleep 0.1; done
  die "munge does not answer"
}

write_conf() {
  mkdir -p "$DIR/state" "$DIR/spool" "$DIR/log" /etc/slurm
  cat >"$CONF" <<EOF
# Written by pillar-pipe scripts/slurm-cluster.sh: a one-node test cluster.
ClusterName=pp-test
SlurmctldHost=${HOST}(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
# Quick turnaround for tests: jobs leave squeue 30 s after they end, a cancelled job
# is killed 5 s after its SIGTERM.
MinJobAge=30
KillWait=5
SchedulerParameters=defer_batch=0
NodeName=${HOST} NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=${HOST} Default=YES MaxTime=INFINITE State=UP
EOF
  # Debian's package reads a cgroup.conf only with cgroup plugins; none here.
}

up() {
  install_if_missing
  start_munge
  write_conf
  if ! alive "$DIR/slurmctld.pid"; then
    /usr/sbin/slurmctld -i || die "slurmctld did not start (see $DIR/log/slurmctld.log)"
  fi
  if ! alive "$DIR/slurmd.pid"; then
    /usr/sbin/slurmd || die "slurmd did not start (see $DIR/log/slurmd.log)"
  fi
  for _ in $(seq 100); do
    if sinfo -h -o '%T' 2>/dev/null | grep -Eq '^(idle|mixed|allocated)'; then
      echo "slurm-cluster: up ($HOST, $(nproc) CPUs, partition debug; state in $DIR)"
      return
    fi
    sleep 0.2
  done
  scontrol update NodeName="$HOST" State=RESUME >/dev/null 2>&1 || true
  sinfo -h -o '%T' 2>/dev/null | grep -Eq '^(idle|mixed|allocated)' \
    || die "the node did not come up: $(sinfo 2>&1 | tail -2) (logs in $DIR/log)"
  echo "slurm-cluster: up ($HOST)"
}

down() {
  for p in slurmd slurmctld; do
    if alive "$DIR/$p.pid"; then
      kill "$(cat "$DIR/$p.pid")"
      for _ in $(seq 50); do alive "$DIR/$p.pid" || break; sleep 0.1; done
    fi
  done
  echo "slurm-cluster: down (munged left running; state kept in $DIR)"
}

case "${1:-}" in
  up) up ;;
  down) down ;;
  status) sinfo && squeue ;;
  *) die "usage: $0 up|down|status" ;;
esac
