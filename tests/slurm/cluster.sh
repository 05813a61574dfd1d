#!/usr/bin/env bash
# A real single-node Slurm cluster on this machine, for tests/slurm.rs.
#
#   bash tests/slurm/cluster.sh start DIR   # installs slurm-wlm and munge if missing (as root),
#                                           # writes DIR/slurm.conf, starts munged, slurmctld
#                                           # and slurmd on localhost, waits until the node is idle
#   bash tests/slurm/cluster.sh stop DIR    # stops the daemons started from DIR
#
# Every client then needs SLURM_CONF=DIR/slurm.conf in its environment. Nothing outside DIR is
# changed except the packages and munge's own key (created by the munge package).
set -euo pipefail

cmd=${1:-}
dir=${2:-}
[[ -n "$cmd" && -n "$dir" ]] || { echo "usage: $0 start|stop DIR" >&2; exit 2; }

install() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v munged >/dev/null; then
        return
    fi
    if [[ $(id -u) -ne 0 ]]; then
        echo "slurm-wlm and munge are missing; install them as root: apt-get install slurm-wlm munge" >&2
        exit 2
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
}

start() {
    install
    mkdir -p "$dir"/{state,spool,munge}
    dir=$(cd "$dir" && pwd)
    local host cpus mem
    host=$(hostname -s 2>/dev/null || uname -n | cut -d. -f1)
    cpus=$(nproc)
    mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2 ))
    cat > "$dir/slurm.conf" <<CONF
ClusterName=aleph-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CryptoType=crypto/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
ReturnToService=2
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
MinJobAge=600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF="$dir/slurm.conf"
    # munge: its own key (the package creates /etc/munge/munge.key), its own socket.
    if [[ ! -s /etc/munge/munge.key ]]; then
        mungekey --create >/dev/null 2>&1 || /usr/sbin/create-munge-key -f >/dev/null
    fi
    mkdir -p /run/munge
    chown munge:munge /run/munge /etc/munge/munge.key 2>/dev/null || true
    if ! pgrep -x munged >/dev/null; then
        runuser -u munge -- munged --pid-file="$dir/munge/munged.pid" 2>/dev/null \
            || munged --force --pid-file="$dir/munge/munged.pid"
    fi
    slurmctld -i
    slurmd
    for _ in $(seq 1 60); do
        if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then
            echo "slurm cluster up: SLURM_CONF=$SLURM_CONF"
            return
        fi
        sleep 1
    done
    echo "the Slurm node did not become idle in 60 s:" >&2
    sinfo >&2 || true
    tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
    exit 1
}

stop() {
    for d in slurmd slurmctld; do
        if [[ -f "$dir/$d.pid" ]]; then
            kill "$(cat "$dir/$d.pid")" 2>/dev/null || true
        fi
    done
    if [[ -f "$dir/munge/munged.pid" ]]; then
        kill "$(cat "$dir/munge/munged.pid")" 2>/dev/null || true
    fi
}

case "$cmd" in
    start) start ;;
    stop) stop ;;
    *) echo "usage: $0 start|stop DIR" >&2; exit 2 ;;
esac
