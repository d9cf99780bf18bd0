#!/usr/bin/env bash
# A one-node SLURM on this machine, for make test-cluster (issue 40): Debian's slurmctld, slurmd
# and munge on localhost, no accounting database.
#   tests/cluster/slurm.sh install   apt-get the packages if slurmctld is missing (needs root)
#   tests/cluster/slurm.sh up        write munge.key and slurm.conf, start munged, slurmctld, slurmd;
#                                    wait until the node is idle
#   tests/cluster/slurm.sh down      stop the three daemons (and any job left)
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
    if ! pgrep -x munged >/dev/null; then
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
    pgrep -x slurmctld >/dev/null || slurmctld
    pgrep -x slurmd >/dev/null || slurmd
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

down() {
    scancel --user="$(id -un)" 2>/dev/null || true
    for daemon in slurmd slurmctld munged; do
        pkill -x "$daemon" 2>/dev/null || true
    done
    local end=$((SECONDS + 20))
    while { pgrep -x slurmd || pgrep -x slurmctld || pgrep -x munged; } >/dev/null && [ $SECONDS -lt $end ]; do
        sleep 0.2
    done
    echo "slurm.sh: SLURM stopped"
}

case "${1:-}" in
    install) install ;;
    up) install; up ;;
    down) down ;;
    *) echo "usage: $0 install|up|down" >&2; exit 2 ;;
esac
