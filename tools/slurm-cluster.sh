#!/usr/bin/env bash
# Starts, stops and shows a private one-node Slurm cluster (munged + slurmctld + slurmd) on this
# machine, for the test suite and for trying `orbcal study` by hand. Everything it writes, the
# daemons' pid, log, state and spool files and the munge key, lives in STATE_DIR; it picks free
# non-default ports and runs its own munged with its own socket, so it neither touches a system
# Slurm or munged nor collides with a second checkout's cluster on the same machine.
set -euo pipefail
PATH=$PATH:/usr/sbin:/sbin   # the daemons and mungekey live in sbin

usage() {
  cat <<'EOF'
Usage: tools/slurm-cluster.sh start|stop|status STATE_DIR

  start   Write a one-node configuration for this machine into STATE_DIR (munge key, slurm.conf,
          env.sh), start munged (as the `munge` user), slurmctld and slurmd, and wait until sinfo
          shows the node idle (at most 60 s). A STATE_DIR left by an earlier run (daemons killed
          or still running) is stopped and wiped first. On failure prints the daemons' log tails,
          stops what it started and exits 1.
  stop    Cancel the cluster's jobs and stop slurmd, slurmctld and munged by their pid files
          (SIGTERM, then SIGKILL after a bounded wait). Stopping a stopped cluster succeeds.
  status  Show sinfo and squeue of the cluster (exit 1 when slurmctld does not answer).

Clients use the cluster through its configuration:  source STATE_DIR/env.sh  (sets SLURM_CONF).
Needs root and Debian's slurmctld, slurmd, slurm-client and munge packages
(tools/install-deps.sh --tests installs them).
EOF
}

die() { echo "slurm-cluster: $*" >&2; exit 1; }

if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then usage; exit 0; fi
[[ $# -eq 2 ]] || { usage >&2; exit 2; }
action=$1
case "$action" in start|stop|status) ;; *) usage >&2; exit 2 ;; esac
[[ -n "$2" ]] || die "STATE_DIR is empty"
state=$(realpath -m "$2")
conf=$state/slurm.conf
marker=$state/.orbcal-slurm-cluster   # says the folder is ours to wipe

# --- processes --------------------------------------------------------------------------------

# True while process $1 runs (a killed daemon stays a zombie until its parent reaps it).
running() { [[ -r /proc/$1/stat ]] && [[ "$(cut -d' ' -f3 "/proc/$1/stat" 2>/dev/null)" != Z ]]; }

# Prints the pid in pid file $1 when that process is alive and its command line names this
# STATE_DIR (so a recycled pid of an unrelated process is never signalled).
live_pid() {
  local pidfile=$1 pid
  [[ -f "$pidfile" ]] || return 1
  pid=$(tr -dc '0-9' <"$pidfile")
  [[ -n "$pid" ]] && running "$pid" || return 1
  tr '\0' '\n' <"/proc/$pid/cmdline" | grep -qF "$state/" || return 1
  echo "$pid"
}

# Stops the daemons of the given pid files together (each takes 1-2 s to exit): SIGTERM, up to
# 10 s, then SIGKILL and up to 5 s more.
stop_daemons() {
  local f pid pids=() files=() i
  for f in "$@"; do
    if pid=$(live_pid "$f"); then pids+=("$pid"); files+=("$f"); else rm -f "$f"; fi
  done
  ((${#pids[@]})) || return 0
  kill -TERM "${pids[@]}" 2>/dev/null || true
  alive() { local p; for p in "${pids[@]}"; do running "$p" && return 0; done; return 1; }
  for ((i = 0; i < 100; i++)); do alive || break; sleep 0.1; done
  if alive; then
    echo "slurm-cluster: ${pids[*]} ignored SIGTERM for 10 s; sending SIGKILL" >&2
    kill -KILL "${pids[@]}" 2>/dev/null || true
    for ((i = 0; i < 50; i++)); do alive || break; sleep 0.1; done
  fi
  if alive; then echo "slurm-cluster: cannot stop ${pids[*]}" >&2; return 1; fi
  rm -f "${files[@]}"
}

# Kills what the jobs of this cluster left behind when slurmd died without ending them (kill -9):
# job step daemons (slurmstepd keeps the slurmd log of this STATE_DIR open) and job processes
# (their environment holds this cluster's SLURM_CONF and a SLURM_JOB_ID).
kill_orphans() {
  local p pid fd mine env
  for p in /proc/[0-9]*; do
    pid=${p#/proc/}
    [[ $pid != "$$" ]] || continue
    mine=0
    if [[ "$(cat "$p/comm" 2>/dev/null)" == slurmstepd ]]; then
      for fd in "$p"/fd/*; do
        [[ "$(readlink "$fd" 2>/dev/null)" == "$state/"* ]] && { mine=1; break; }
      done
    else
      env=$( { tr '\0' '\n' <"$p/environ"; } 2>/dev/null) || continue
      grep -qxF "SLURM_CONF=$conf" <<<"$env" && grep -q '^SLURM_JOB_ID=' <<<"$env" && mine=1
    fi
    if ((mine)); then kill -KILL "$pid" 2>/dev/null || true; fi
  done
}

stop_cluster() {
  local rc=0
  if [[ -f "$conf" ]] && live_pid "$state/slurmctld.pid" >/dev/null; then
    # Cancel every job of its one partition so that their steps end with the cluster (bounded).
    SLURM_CONF=$conf timeout 10 scancel --quiet --partition=debug 2>/dev/null || true
    local i
    for ((i = 0; i < 50; i++)); do
      [[ -z "$(SLURM_CONF=$conf timeout 5 squeue --noheader --states=RUNNING,COMPLETING 2>/dev/null)" ]] && break
      sleep 0.2
    done
  fi
  stop_daemons "$state/slurmd.pid" "$state/slurmctld.pid" "$state/munge/munged.pid" || rc=1
  kill_orphans
  return $rc
}

# --- start ------------------------------------------------------------------------------------

# Prints a TCP port that no socket of this machine uses, and whose successor is free too, below
# Linux's ephemeral range (32768 and up) so that no outgoing connection takes it meanwhile.
free_port_pair() {
  local p i
  for ((i = 0; i < 200; i++)); do
    p=$((10000 + RANDOM % 22000))
    if [[ -z "$(ss -Htan "( sport = :$p or sport = :$((p + 1)) )")" ]]; then
      echo "$p"
      return 0
    fi
  done
  die "found no free TCP port pair in 10000..32000"
}

log_tails() {
  local f
  for f in "$state/munge/munged.log" "$state/slurmctld.log" "$state/slurmd.log"; do
    [[ -f "$f" ]] || continue
    echo "----- tail of $f" >&2
    tail -n 20 "$f" >&2
  done
}

write_conf() {
  local ctld_port=$1 host=$2 hw
  # This machine's topology as slurmd sees it; memory 5 % under, so that slurmd never reports less.
  hw=$(slurmd -C | head -n 1)
  local cpus boards sockets cores threads mem
  cpus=$(sed -n 's/.* CPUs=\([0-9]*\).*/\1/p' <<<"$hw")
  boards=$(sed -n 's/.* Boards=\([0-9]*\).*/\1/p' <<<"$hw")
  sockets=$(sed -n 's/.* SocketsPerBoard=\([0-9]*\).*/\1/p' <<<"$hw")
  cores=$(sed -n 's/.* CoresPerSocket=\([0-9]*\).*/\1/p' <<<"$hw")
  threads=$(sed -n 's/.* ThreadsPerCore=\([0-9]*\).*/\1/p' <<<"$hw")
  mem=$(sed -n 's/.* RealMemory=\([0-9]*\).*/\1/p' <<<"$hw")
  [[ -n "$cpus" && -n "$sockets" && -n "$cores" && -n "$threads" && -n "$mem" ]] ||
    die "cannot read this machine's CPUs and memory from 'slurmd -C': $hw"
  : >"$state/plugstack.conf"   # no SPANK plugins (not /etc/slurm/plugstack.conf)
  cat >"$conf.tmp" <<EOF
# One-node test cluster written by tools/slurm-cluster.sh; everything lives in $state.
ClusterName=orbcal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$((ctld_port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$state/munge/munged.socket
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/spool
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$state/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
MailProg=/bin/true
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
# The node becomes usable as soon as its slurmd registers.
ReturnToService=2
# scancel: SIGKILL 5 s after SIGTERM (default 30 s).
KillWait=5
# No accounting database: squeue shows a finished job's state for 5 minutes.
MinJobAge=300
# Start batch jobs (array tasks too) at the next scheduling pass, not up to 3 s later.
SchedulerParameters=batch_sched_delay=0
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus Boards=${boards:-1} SocketsPerBoard=$sockets CoresPerSocket=$cores ThreadsPerCore=$threads RealMemory=$((mem * 95 / 100)) State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$conf.tmp" "$conf"
}

start_munged() {
  local m=$state/munge
  mkdir -p "$m"
  mungekey -c -k "$m/munge.key"
  chown -R munge:munge "$m"
  chmod 755 "$m"   # clients need to reach the socket; the key itself is 0600
  chmod 600 "$m/munge.key"
  # --force: run even where a folder above STATE_DIR is group- or world-writable (munged then
  # only warns); the key is this test cluster's own, made above.
  runuser -u munge -- munged --key-file="$m/munge.key" --socket="$m/munged.socket" \
    --pid-file="$m/munged.pid" --log-file="$m/munged.log" --seed-file="$m/munged.seed" --force ||
    return 1
  local i
  for ((i = 0; i < 50; i++)); do
    [[ -S "$m/munged.socket" ]] && munge -n -S "$m/munged.socket" | unmunge -S "$m/munged.socket" >/dev/null 2>&1 &&
      return 0
    sleep 0.1
  done
  echo "slurm-cluster: munged did not answer on $m/munged.socket within 5 s" >&2
  return 1
}

# Waits up to 60 s for sinfo to show the node idle; fails at once when slurmctld or slurmd dies
# (a port taken meanwhile, a bad configuration).
wait_idle() {
  local st="" d end=$((SECONDS + 60))
  while ((SECONDS < end)); do
    st=$(SLURM_CONF=$conf timeout 5 sinfo --noheader --Node --format=%T 2>/dev/null || true)
    [[ "$st" == idle ]] && return 0
    for d in slurmctld slurmd; do
      if [[ -f "$state/$d.pid" ]] && ! live_pid "$state/$d.pid" >/dev/null; then
        echo "slurm-cluster: $d exited during start" >&2
        return 1
      fi
    done
    sleep 0.2
  done
  echo "slurm-cluster: the node is not idle after 60 s (sinfo state: '${st:-no answer}')" >&2
  return 1
}

start_cluster() {
  local b
  for b in munged mungekey munge unmunge slurmctld slurmd sinfo squeue scancel sbatch ss runuser; do
    command -v "$b" >/dev/null ||
      die "'$b' not found: run tools/install-deps.sh --tests (Debian packages slurmctld, slurmd, slurm-client, munge)"
  done
  [[ $(id -u) -eq 0 ]] || die "start needs root (SlurmUser=root, munged run as the munge user)"
  id munge >/dev/null 2>&1 || die "no 'munge' user: run tools/install-deps.sh --tests"
  local host
  host=$(hostname -s)
  # Unix socket paths hold at most 107 bytes: slurmstepd's STATE_DIR/spool/HOST_JOBID.STEPID is
  # the longest (job and step ids up to 10 digits each).
  local longest=$state/spool/${host}_0123456789.0123456789
  ((${#longest} <= 107)) ||
    die "STATE_DIR $state is too long for Slurm's Unix sockets (${#state} characters; at most $((107 - ${#longest} + ${#state})))"
  if [[ -e "$state" ]]; then
    if [[ -f "$marker" ]]; then
      stop_cluster || die "cannot stop the daemons of the earlier cluster in $state"
      rm -rf "$state"
    elif [[ -n "$(ls -A "$state")" ]]; then
      die "$state exists, is not empty and was not made by this script; not touching it"
    fi
  fi
  mkdir -p "$state/ctld" "$state/spool"
  chmod 755 "$state"
  : >"$marker"
  local port t0 t1 attempt
  t0=$(date +%s.%N)
  for attempt in 1 2 3; do
    port=$(free_port_pair)
    write_conf "$port" "$host"
    if start_munged && slurmctld -f "$conf" && slurmd -f "$conf" && wait_idle; then break; fi
    log_tails
    stop_cluster || true
    # Another program took one of the two ports between the check and the bind: try new ones.
    if ((attempt < 3)) && grep -qs 'Address already in use' "$state/slurmctld.log" "$state/slurmd.log"; then
      echo "slurm-cluster: port $port or $((port + 1)) was taken meanwhile; retrying with others" >&2
      rm -rf "$state/munge" "$state"/*.log "$state/ctld"/* "$state/spool"/*
      continue
    fi
    echo "slurm-cluster: start failed; state and logs kept in $state" >&2
    exit 1
  done
  t1=$(date +%s.%N)
  cat >"$state/env.sh.tmp" <<EOF
# Source this to use the Slurm test cluster in $state.
export SLURM_CONF=$conf
EOF
  mv "$state/env.sh.tmp" "$state/env.sh"
  echo "slurm-cluster: node $host idle $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s after start" \
    "(slurmctld port $port, slurmd port $((port + 1)))"
  echo "export SLURM_CONF=$conf    # or: source $state/env.sh"
}

case "$action" in
  start) start_cluster ;;
  stop)
    if [[ -e "$state" && ! -f "$marker" ]]; then die "$state was not made by this script"; fi
    [[ -d "$state" ]] || exit 0
    stop_cluster || exit 1
    echo "slurm-cluster: stopped ($state)"
    ;;
  status)
    [[ -f "$conf" ]] || die "no cluster in $state (no slurm.conf)"
    live_pid "$state/slurmctld.pid" >/dev/null || die "the cluster in $state is not running (no slurmctld)"
    export SLURM_CONF=$conf
    timeout 10 sinfo || exit 1
    timeout 10 squeue
    ;;
esac
