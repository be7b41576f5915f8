#!/usr/bin/env bash
# A single-node SLURM on this machine, to run the workflow through the real
# snakemake-executor-plugin-slurm (profiles/slurm) without a cluster.
#
#   scripts/slurm-local.sh up       install slurm-wlm + munge (apt, once), write the
#                                   config, start munged, slurmctld, slurmd, wait idle
#   scripts/slurm-local.sh status   daemons, node state, queue
#   scripts/slurm-local.sh env      print the export line clients need (SLURM_CONF)
#   scripts/slurm-local.sh down     cancel its jobs, stop the daemons it started
#
# Everything lives in $SPL_AL_SLURM_DIR (default /tmp/spl-al-slurm): slurm.conf, the
# munge key and socket, state, logs, and the pid files the daemons write. Clients
# (sbatch, squeue, sinfo, and Snakemake through them) find this cluster through
# SLURM_CONF=$SPL_AL_SLURM_DIR/slurm.conf, and /etc/slurm/slurm.conf is a symlink to it
# while the cluster is up: snakemake-executor-plugin-slurm-jobstep (0.6) removes every
# SLURM_* variable, SLURM_CONF too, before the srun it runs inside each job, so that
# srun only finds the default path. `up` refuses when that path holds another file.
#
# No slurmdbd: accounting is off, so run Snakemake with `--slurm-status-command squeue`
# (MinJobAge is 600 s here, long enough for the plugin to trust squeue).
# `down` stops only the daemons whose pid files this script's config names, after
# checking each pid still runs that daemon. `up` refuses to run beside a slurmctld or
# slurmd it did not start. Needs root (apt, daemons running as root). Debian/Ubuntu.
set -euo pipefail

DIR=${SPL_AL_SLURM_DIR:-/tmp/spl-al-slurm}
CTLD_PORT=${SPL_AL_SLURM_CTLD_PORT:-6817}
SLURMD_PORT=${SPL_AL_SLURM_SLURMD_PORT:-6818}
PARTITION=${SPL_AL_SLURM_PARTITION:-local}
CONF=$DIR/slurm.conf
ETC_CONF=/etc/slurm/slurm.conf
DAEMONS=(slurmd slurmctld munged) # stop order; started in reverse

say() { echo "slurm-local: $*"; }
die() {
  echo "slurm-local: $*" >&2
  exit 1
}

pidfile() { echo "$DIR/run/$1.pid"; }

# The pid of our daemon $1 when its pid file names a live process running it.
our_pid() {
  local file pid
  file=$(pidfile "$1")
  [[ -s $file ]] || return 1
  pid=$(tr -dc '0-9' <"$file")
  [[ -n $pid && -r /proc/$pid/comm ]] || return 1
  [[ $(cat "/proc/$pid/comm") == "$1" ]] || return 1
  echo "$pid"
}

# Refuse when a daemon named $1 runs that is not ours.
refuse_foreign() {
  local mine others
  mine=$(our_pid "$1" || true)
  others=$(pgrep -x "$1" || true)
  for pid in $others; do
    if [[ $pid != "$mine" ]]; then
      die "another $1 (pid $pid) is running, not started by this script; stop it yourself or use that cluster."
    fi
  done
}

install_packages() {
  if command -v slurmctld >/dev/null && command -v slurmd >/dev/null &&
    command -v sbatch >/dev/null && command -v munged >/dev/null; then
    return
  fi
  [[ $(id -u) == 0 ]] || die "slurm-wlm and munge are missing and installing them needs root."
  command -v apt-get >/dev/null || die "slurm-wlm and munge are missing and this is not a Debian/Ubuntu system (no apt-get)."
  say "installing slurm-wlm and munge from apt"
  # On a systemd host the packages would start the distribution's own munged and
  # slurmctld; a policy-rc.d that says "no" (exit 101) keeps them off during install.
  local policy=/usr/sbin/policy-rc.d
  if [[ ! -e $policy ]]; then
    printf '#!/bin/sh\nexit 101\n' >"$policy"
    chmod +x "$policy"
    trap "rm -f $policy" EXIT
  fi
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
}

write_config() {
  mkdir -p "$DIR"/{run,log,state,spool,munge}
  chmod 700 "$DIR" "$DIR/munge"
  local node host
  host=$(hostname -s)
  # "NodeName=host CPUs=.. Boards=.. SocketsPerBoard=.. CoresPerSocket=.. ThreadsPerCore=.. RealMemory=.."
  node=$(slurmd -C | head -n1)
  [[ $node == NodeName=* ]] || die "slurmd -C did not describe this host (got: $node)."
  cat >"$CONF" <<EOF
# Written by scripts/slurm-local.sh: a single-node cluster on $host.
ClusterName=spl-al-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$(pidfile slurmctld)
SlurmdPidFile=$(pidfile slurmd)
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
# no cgroups in containers: track job processes through /proc, no task binding
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SwitchType=switch/none
# no slurmdbd: sacct has nothing to read, the plugin polls squeue, which needs
# finished jobs to stay visible for a while (MinJobAge, seconds)
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MinJobAge=600
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=$PARTITION Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  if [[ ! -s $DIR/munge/munge.key ]]; then
    mungekey --create --keyfile="$DIR/munge/munge.key" >/dev/null
  fi
  chmod 600 "$DIR/munge/munge.key"
}

start_daemons() {
  if ! our_pid munged >/dev/null; then
    munged --force --socket="$DIR/munge/munge.socket" --key-file="$DIR/munge/munge.key" \
      --pid-file="$(pidfile munged)" --log-file="$DIR/log/munged.log" \
      --seed-file="$DIR/munge/munged.seed"
  fi
  export SLURM_CONF=$CONF
  our_pid slurmctld >/dev/null || slurmctld -f "$CONF"
  our_pid slurmd >/dev/null || slurmd -f "$CONF"
}

wait_idle() {
  local state=""
  for _ in $(seq 120); do
    state=$(SLURM_CONF=$CONF sinfo -h -N -o %t 2>/dev/null | head -n1 || true)
    if [[ $state == idle ]]; then
      say "node $(hostname -s) idle in partition $PARTITION ($CONF)"
      return
    fi
    sleep 0.5
  done
  die "the node did not become idle in 60 s (state: '${state:-no answer}'); see $DIR/log/."
}

# /etc/slurm/slurm.conf: ours when it is a symlink to $CONF.
etc_conf_is_ours() { [[ -L $ETC_CONF && $(readlink "$ETC_CONF") == "$CONF" ]]; }

refuse_foreign_etc_conf() {
  if [[ -e $ETC_CONF || -L $ETC_CONF ]] && ! etc_conf_is_ours; then
    die "$ETC_CONF exists and is not this script's link to $CONF; the jobs' srun reads only that path, so move it aside or use the cluster it describes."
  fi
}

cmd_up() {
  refuse_foreign slurmctld
  refuse_foreign slurmd
  refuse_foreign_etc_conf
  install_packages
  write_config
  if ! etc_conf_is_ours; then
    mkdir -p "$(dirname "$ETC_CONF")"
    ln -s "$CONF" "$ETC_CONF"
  fi
  start_daemons
  wait_idle
  cmd_env
}

cmd_down() {
  if our_pid slurmctld >/dev/null; then
    # cancel what is left, and give slurmd a moment to end the jobs' processes
    export SLURM_CONF=$CONF
    scancel --full --partition="$PARTITION" 2>/dev/null || true
    for _ in $(seq 60); do
      [[ -z $(squeue -h -t RUNNING,COMPLETING -o %i 2>/dev/null) ]] && break
      sleep 0.5
    done
  fi
  local pid
  for daemon in "${DAEMONS[@]}"; do
    if pid=$(our_pid "$daemon"); then
      kill "$pid"
      for _ in $(seq 100); do
        [[ -d /proc/$pid ]] || break
        sleep 0.1
      done
      if [[ -d /proc/$pid ]]; then
        kill -9 "$pid"
      fi
      say "stopped $daemon (pid $pid)"
    fi
    rm -f "$(pidfile "$daemon")"
  done
  if etc_conf_is_ours; then
    rm -f "$ETC_CONF"
  fi
}

cmd_status() {
  local pid any=0
  for daemon in munged slurmctld slurmd; do
    if pid=$(our_pid "$daemon"); then
      say "$daemon running (pid $pid)"
      any=1
    else
      say "$daemon not running"
    fi
  done
  if ((any)); then
    SLURM_CONF=$CONF sinfo -N -o "%N %P %t %c %m" || true
    SLURM_CONF=$CONF squeue || true
  fi
}

cmd_env() { echo "export SLURM_CONF=$CONF"; }

case "${1:-}" in
  up) cmd_up ;;
  down) cmd_down ;;
  status) cmd_status ;;
  env) cmd_env ;;
  *) die "usage: $0 up|down|status|env (got '${1:-}')." ;;
esac
