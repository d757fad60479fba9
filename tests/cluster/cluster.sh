# A one-node Slurm cluster for the tests (sourced, not a test itself): munged, slurmctld
# and slurmd of Debian's slurm-wlm 22.05, run as root with every file they use in one
# private folder, on ports nothing else listens on. The client commands (sbatch, squeue,
# scancel, scontrol) reach it through SLURM_CONF, which cluster_start exports.
#
#   cluster_start DIR    starts the cluster in DIR (an empty folder); exit 77 (skip) when
#                        it cannot run here: not root, or slurm-wlm or munge missing;
#                        exit 1 when it should run but does not come up
#   cluster_stop         stops every daemon cluster_start started, and every job they
#                        left running (stopping slurmd does not end them); safe to call
#                        twice and from a trap
#   cluster_wait JOB...  waits until the jobs (and every task of an array) have ended;
#                        prints "JOB STATE" per job or array task
#
# What this cluster needs, found on CI-like machines (no systemd, root, cgroup layouts of
# any kind): cgroup.conf with CgroupPlugin=cgroup/v1, since slurmd loads a cgroup plugin
# even with proctrack/linuxproc and task/none and its autodetection kills it where
# /sys/fs/cgroup is unusual; munged wants its socket folder and every parent
# world-traversable; SchedulerParameters=batch_sched_delay=0 starts a job within a
# second; KillWait=15 leaves bbc-precompute the seconds it may take to stop on SIGTERM
# (scancel) before SIGKILL. `sbatch --wait` is not used: it polls at 2, 8, then every
# 32 s, and hangs on a dependency that can no longer be met.

CLUSTER_DIR=""
CLUSTER_PIDS=""
CLUSTER_LIB=${BBC_SOURCE_DIR:-.}/tests/cluster/cluster.sh
# A folder the watcher removes too, should the test die without its trap (its scratch).
CLUSTER_REMOVE=${CLUSTER_REMOVE:-}

cluster_skip() { echo "SKIPPED: $*" >&2; exit 77; }
cluster_fail() { echo "FAILED: $*" >&2; cluster_logs; exit 1; }

# The daemons' logs, for a failure's report.
cluster_logs() {
  [ -n "$CLUSTER_DIR" ] || return 0
  for log in "$CLUSTER_DIR"/log/*.log; do
    [ -f "$log" ] || continue
    echo "--- $(basename "$log") (last lines)" >&2
    tail -n 15 "$log" >&2
  done
}

# The TCP ports that something listens on (IPv4 and IPv6), one a line, in decimal.
cluster_ports_in_use() {
  cat /proc/net/tcp /proc/net/tcp6 2>/dev/null |
    awk '$4 == "0A" { split($2, a, ":"); print a[2] }' |
    while read -r c_hex; do printf '%d\n' "0x$c_hex"; done
}

# Two consecutive free ports from a range above Slurm's own (6817, 6818), so that a real
# Slurm on the machine and other clusters of this kind are left alone.
cluster_pick_ports() {
  c_used=$(cluster_ports_in_use)
  c_port=$((16817 + $$ % 2000 * 2))
  while [ "$c_port" -lt 65000 ]; do
    if ! printf '%s\n' "$c_used" | grep -qx -e "$c_port" -e "$((c_port + 1))"; then
      echo "$c_port"
      return 0
    fi
    c_port=$((c_port + 2))
  done
  return 1
}

# The pids of the processes this cluster started: its daemons and whatever they spawned
# carry BBC_CLUSTER=<dir> in their environment; a job's processes carry the submitter's
# SLURM_CONF together with a SLURM_JOB_ID.
cluster_processes() {
  for c_env in /proc/[0-9]*/environ; do
    c_pid=${c_env#/proc/}
    c_pid=${c_pid%/environ}
    [ "$c_pid" = "$$" ] && continue
    { tr '\0' '\n' <"$c_env"; } 2>/dev/null | awk -v dir="$CLUSTER_DIR" -v pid="$c_pid" '
      $0 == "BBC_CLUSTER=" dir { mine = 1 }
      $0 == "SLURM_CONF=" dir "/slurm.conf" { conf = 1 }
      /^SLURM_JOB_ID=/ { job = 1 }
      END { if (mine || (conf && job)) print pid }'
  done
}

cluster_start() {
  CLUSTER_DIR=$1
  if [ "$(id -u)" != 0 ]; then
    cluster_unavailable "not root (slurmd runs jobs as their user, and the test's as root)"
  fi
  for c_tool in munged slurmctld slurmd sbatch squeue scontrol scancel sinfo; do
    command -v "$c_tool" >/dev/null 2>&1 ||
      cluster_unavailable "$c_tool is missing (sh scripts/install-deps.sh installs it)"
  done
  mkdir -p "$CLUSTER_DIR/munge" "$CLUSTER_DIR/state" "$CLUSTER_DIR/spool" "$CLUSTER_DIR/log" \
    "$CLUSTER_DIR/run"
  # munged refuses a socket folder that others cannot traverse, and a key others can read.
  chmod 755 "$CLUSTER_DIR" "$CLUSTER_DIR/munge"
  chmod 700 "$CLUSTER_DIR/state" "$CLUSTER_DIR/spool"
  c_dir=$CLUSTER_DIR
  while [ "$c_dir" != / ]; do
    c_dir=$(dirname "$c_dir")
    [ -n "$(find "$c_dir" -maxdepth 0 -perm -o+x)" ] ||
      cluster_unavailable "$c_dir is not world-traversable, which munged needs (set TMPDIR)"
  done
  (umask 077 && dd if=/dev/urandom of="$CLUSTER_DIR/munge/munge.key" bs=1024 count=1 2>/dev/null)
  chmod 400 "$CLUSTER_DIR/munge/munge.key"
  c_ports=$(cluster_pick_ports) || cluster_fail "no free TCP port for slurmctld and slurmd"
  c_cpus=$(nproc)
  c_host=$(hostname -s)
  cat >"$CLUSTER_DIR/slurm.conf" <<CONF
ClusterName=bbctest
SlurmctldHost=$c_host(127.0.0.1)
SlurmctldPort=$c_ports
SlurmdPort=$((c_ports + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$CLUSTER_DIR/munge/munge.socket
StateSaveLocation=$CLUSTER_DIR/state
SlurmdSpoolDir=$CLUSTER_DIR/spool
SlurmctldPidFile=$CLUSTER_DIR/run/slurmctld.pid
SlurmdPidFile=$CLUSTER_DIR/run/slurmd.pid
SlurmctldLogFile=$CLUSTER_DIR/log/slurmctld.log
SlurmdLogFile=$CLUSTER_DIR/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
ReturnToService=2
KillWait=15
MinJobAge=600
InactiveLimit=0
NodeName=bbcnode NodeHostname=$c_host NodeAddr=127.0.0.1 CPUs=$c_cpus State=UNKNOWN
PartitionName=test Nodes=bbcnode Default=YES MaxTime=INFINITE State=UP
CONF
  echo "CgroupPlugin=cgroup/v1" >"$CLUSTER_DIR/cgroup.conf"
  SLURM_CONF=$CLUSTER_DIR/slurm.conf
  export SLURM_CONF

  # Watches this shell: should it die without running its trap (SIGKILL, a test
  # timeout), the watcher stops the cluster and removes its folder. It is detached (a
  # new session, child of init) so that killing the test's process tree misses it.
  (setsid sh "$CLUSTER_LIB" --watch "$$" "$CLUSTER_DIR" \
    "$CLUSTER_REMOVE" </dev/null >/dev/null 2>&1 &)

  BBC_CLUSTER=$CLUSTER_DIR munged -f --socket="$CLUSTER_DIR/munge/munge.socket" \
    --key-file="$CLUSTER_DIR/munge/munge.key" --pid-file="$CLUSTER_DIR/run/munged.pid" \
    --log-file="$CLUSTER_DIR/log/munged.log" --seed-file="$CLUSTER_DIR/munge/munged.seed" \
    >>"$CLUSTER_DIR/log/start.log" 2>&1 ||
    cluster_fail "munged did not start"
  CLUSTER_PIDS="$(cat "$CLUSTER_DIR/run/munged.pid")"
  BBC_CLUSTER=$CLUSTER_DIR slurmctld -f "$SLURM_CONF" -i >>"$CLUSTER_DIR/log/start.log" 2>&1 ||
    cluster_fail "slurmctld did not start"
  cluster_wait_file "$CLUSTER_DIR/run/slurmctld.pid" || cluster_fail "slurmctld wrote no pid file"
  CLUSTER_PIDS="$CLUSTER_PIDS $(cat "$CLUSTER_DIR/run/slurmctld.pid")"
  BBC_CLUSTER=$CLUSTER_DIR slurmd -f "$SLURM_CONF" -N bbcnode \
    >>"$CLUSTER_DIR/log/start.log" 2>&1 || cluster_fail "slurmd did not start"
  cluster_wait_file "$CLUSTER_DIR/run/slurmd.pid" || cluster_fail "slurmd wrote no pid file"
  CLUSTER_PIDS="$CLUSTER_PIDS $(cat "$CLUSTER_DIR/run/slurmd.pid")"
  # The node is up once the controller has heard from slurmd.
  c_i=0
  while [ "$c_i" -lt 300 ]; do
    c_state=$(sinfo -h -n bbcnode -o %T 2>/dev/null)
    case $c_state in
      idle* | mixed* | allocated*) return 0 ;;
    esac
    sleep 0.1
    c_i=$((c_i + 1))
  done
  cluster_fail "the node did not come up in 30 s (state '$c_state')"
}

# cluster_wait_file FILE: waits up to 10 s for FILE to exist and not be empty.
cluster_wait_file() {
  c_i=0
  while [ ! -s "$1" ] && [ "$c_i" -lt 100 ]; do
    sleep 0.1
    c_i=$((c_i + 1))
  done
  [ -s "$1" ]
}

cluster_unavailable() {
  # In CI the suite installs the packages and runs as root (scripts/test.sh), so there a
  # cluster that cannot start is a failure, never a skip.
  if [ "${CI:-}" = true ]; then
    cluster_fail "$* (and CI is set: this test must run in CI)"
  fi
  cluster_skip "$*"
}

cluster_stop() {
  [ -n "$CLUSTER_DIR" ] && [ -d "$CLUSTER_DIR" ] || return 0
  if [ -n "${SLURM_CONF:-}" ] && [ -n "$CLUSTER_PIDS" ]; then
    # Cancel every job (their processes outlive slurmd otherwise) and give them KillWait.
    scancel --quiet --user=root >/dev/null 2>&1
    c_i=0
    while [ -n "$(squeue -h -o %i 2>/dev/null)" ] && [ "$c_i" -lt 50 ]; do
      sleep 0.1
      c_i=$((c_i + 1))
    done
  fi
  for c_pid in $CLUSTER_PIDS; do kill -TERM "$c_pid" 2>/dev/null; done
  c_i=0
  while [ "$c_i" -lt 50 ]; do
    c_alive=""
    for c_pid in $CLUSTER_PIDS; do kill -0 "$c_pid" 2>/dev/null && c_alive="$c_alive $c_pid"; done
    [ -z "$c_alive" ] && break
    sleep 0.1
    c_i=$((c_i + 1))
  done
  for c_pid in $CLUSTER_PIDS; do kill -KILL "$c_pid" 2>/dev/null; done
  # Whatever the daemons spawned and left (slurmstepd, a job's processes).
  for c_pid in $(cluster_processes); do kill -KILL "$c_pid" 2>/dev/null; done
  CLUSTER_PIDS=""
}

# cluster_wait JOB...: waits until no task of the jobs is pending or running (polling
# the controller every 0.2 s), then prints "ID STATE" for each job or array task, as
# scontrol shows them (COMPLETED, FAILED, CANCELLED, ...). Jobs pending on a dependency
# that can no longer be met (and those waiting on them) count as ended, as PENDING.
# Fails after BBC_CLUSTER_TIMEOUT seconds (default 300).
cluster_wait() {
  c_limit=$(( ${BBC_CLUSTER_TIMEOUT:-300} * 5 ))
  c_i=0
  while :; do
    c_busy=$(squeue -h -j "$(echo "$@" | tr ' ' ',')" -o '%T %r' 2>/dev/null || true)
    [ -z "$c_busy" ] && break
    # Stuck for good: every job left waits on a dependency and one of them on one that
    # can never be met (the others wait on it).
    if ! printf '%s\n' "$c_busy" | grep -qv '^PENDING Dependency' &&
      printf '%s\n' "$c_busy" | grep -q '^PENDING DependencyNeverSatisfied'; then
      break
    fi
    [ "$c_i" -ge "$c_limit" ] &&
      cluster_fail "jobs $* still running after ${BBC_CLUSTER_TIMEOUT:-300} s"
    sleep 0.2
    c_i=$((c_i + 1))
  done
  for c_job in "$@"; do
    scontrol -o show job "$c_job" 2>/dev/null | tr ' ' '\n' | awk -F= '
      $1 == "JobId" { if (id != "") print id, state; id = $2; array = ""; state = "" }
      $1 == "ArrayJobId" { array = $2 }
      $1 == "ArrayTaskId" { id = array "_" $2 }
      $1 == "JobState" { state = $2 }
      END { if (id != "") print id, state }'
  done
}

# sh cluster.sh --watch PID DIR REMOVE: the watcher started by cluster_start.
if [ "${1:-}" = --watch ]; then
  c_watched=$2
  CLUSTER_DIR=$3
  # At most an hour, whatever happens.
  c_i=0
  while kill -0 "$c_watched" 2>/dev/null && [ "$c_i" -lt 3600 ]; do
    sleep 1
    c_i=$((c_i + 1))
  done
  [ -d "$CLUSTER_DIR" ] || exit 0
  CLUSTER_PIDS=$(cat "$CLUSTER_DIR"/run/*.pid 2>/dev/null | tr '\n' ' ')
  SLURM_CONF=$CLUSTER_DIR/slurm.conf
  export SLURM_CONF
  cluster_stop
  [ -n "$4" ] && rm -rf "$4"
  exit 0
fi
