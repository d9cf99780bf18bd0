#!/usr/bin/env bash
# A one-node SLURM on this machine, for make test-cluster (issue 40): Debian's slurmctld, slurmd
# and munge on localhost, no accounting database.
#   tests/cluster/slurm.sh install   apt-get the packages if slurmctld is missing (needs root)
#   tests/cluster/slurm.sh up        write munge.key and slurm.conf, start munged, slurmctld, slurmd;
#                                    wait until the node is idle
#   tests/cluster/slurm.sh down      stop every SLURM process: the jobs, their steps (slurmstepd and
#                                    what they started), the three daemons; exit 1 if one is left
# Its state (config, logs, spool) lives in $SLURM_STATE (default /tmp/floe-impact-slurm).
set -euo pipefail
STATE=${SLURM_STATE:-/tmp/floe-impact-slurm}
CONF=/etc/slurm/slurm.conf

install() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v munged >/dev/null; then
        return
    fi
    [ "$(id -u)" = 0 ] || { echo "slurm.sh: installing SLURM needs root (apt-get)" >&2; exit 2; }
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge >/dev/null
}

up() {
    [ "$(id -u)" = 0 ] || { echo "slurm.sh: starting slurmd needs root" >&2; exit 2; }
    mkdir -p "$STATE"/{spool/ctld,spool/d,log} /run/munge /etc/munge /etc/slurm
    if [ ! -s /etc/munge/munge.key ]; then
        dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key status=none
    fi
    chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
    chmod 0400 /etc/munge/munge.key
    chmod 0755 /run/munge
    if [ -z "$(alive munged)" ]; then
        runuser -u munge -- /usr/sbin/munged
    fi
    local host cpus memory
    host=$(hostname -s)
    cpus=$(nproc)
    memory=$(awk '/MemTotal/ {print int($2 / 1024 * 0.9)}' /proc/meminfo)     # MB, as slurmd sees it
    cat > "$CONF" <<CONF
# written by floe-impact's tests/cluster/slurm.sh: one node, this machine
ClusterName=floe-impact-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$STATE/spool/ctld
SlurmdSpoolDir=$STATE/spool/d
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
ProctrackType=proctrack/pgid
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
ReturnToService=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
    # a fresh start forgets the jobs of an earlier one (-c: their nodes' daemons are gone, and a
    # recovered job would stay completing for ever, the node never idle)
    [ -n "$(alive slurmctld)" ] || slurmctld -c
    if [ -z "$(alive slurmd)" ]; then
        rm -rf "${STATE:?}"/spool/d/*
        slurmd
    fi
    local end=$((SECONDS + 60))
    until sinfo -h -o %T 2>/dev/null | grep -qx idle; do
        if [ $SECONDS -ge $end ]; then
            echo "slurm.sh: the node did not become idle within 60 s:" >&2
            sinfo >&2 || true
            tail -n 20 "$STATE"/log/*.log >&2 || true
            exit 1
        fi
        sleep 0.5
    done
    echo "slurm.sh: SLURM up on $host ($cpus CPUs, $memory MB): $(sinfo -h -o '%P %T %D')"
}

# every process of the SLURM this script runs: the daemons, each job step's slurmstepd, and what
# the jobs started under them
DAEMONS="slurmctld slurmd slurmstepd munged"

alive() {         # the pids of the processes named $1, not counting zombies (init reaps them late)
    ps -C "$1" -o pid=,stat= 2>/dev/null | awk '$2 !~ /^Z/ {print $1}'
    return 0
}

descendants() {
    local child
    for child in $(ps --ppid "$1" -o pid=,stat= 2>/dev/null | awk '$2 !~ /^Z/ {print $1}'); do
        echo "$child"
        descendants "$child"
    done
}

slurm_pids() {
    local daemon pid
    for daemon in $DAEMONS; do
        for pid in $(alive "$daemon"); do
            echo "$pid"
            [ "$daemon" = slurmstepd ] && descendants "$pid"
        done
    done
    return 0
}

down() {
    # the jobs first (a cancelled job's steps can outlive it), then every daemon and job process:
    # TERM, up to 20 s to go, then KILL; whatever the jobs did, nothing is left running
    scancel --user="$(id -un)" 2>/dev/null || true
    local end=$((SECONDS + 5))
    while squeue -h 2>/dev/null | grep -q . && [ $SECONDS -lt $end ]; do
        sleep 0.2
    done
    local pids
    pids=$(slurm_pids)
    [ -n "$pids" ] && kill -TERM $pids 2>/dev/null
    end=$((SECONDS + 20))
    while [ -n "$(slurm_pids)" ] && [ $SECONDS -lt $end ]; do
        sleep 0.2
    done
    pids="$(slurm_pids) $pids"
    kill -KILL $pids 2>/dev/null || true
    sleep 0.5
    if [ -n "$(slurm_pids)" ]; then
        echo "slurm.sh: still running after SIGKILL:" >&2
        ps -o pid,ppid,stat,cmd -p "$(slurm_pids | tr '\n' ',' | sed 's/,$//')" >&2 || true
        exit 1
    fi
    echo "slurm.sh: SLURM stopped (no slurmctld, slurmd, slurmstepd, munged or job process left)"
}

case "${1:-}" in
    install) install ;;
    up) install; up ;;
    down) down ;;
    *) echo "usage: $0 install|up|down" >&2; exit 2 ;;
esac
