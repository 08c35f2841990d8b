#!/usr/bin/env bash
# A single-node Slurm on loopback for the e2e test `slurm_runs_a_study_as_a_job_array`:
# installs the distribution's slurm-wlm and munge when they are missing (as root), writes a
# one-node configuration under $1 (default /tmp/waamtwin-slurm), starts munged, slurmctld and
# slurmd if they are not running, and waits until the node takes jobs. Idempotent.
# Prints the path of slurm.conf (export it as SLURM_CONF).
set -euo pipefail
dir=${1:-/tmp/waamtwin-slurm}
mkdir -p "$dir/state" "$dir/spool" "$dir/log"

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    if [ "$(id -u)" != 0 ]; then
        echo "slurm-wlm and munge are missing and installing them needs root" >&2
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >&2
    apt-get install -y -qq slurm-wlm munge >&2
fi

if [ ! -s /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null
    chown munge:munge /etc/munge/munge.key 2>/dev/null || true
    chmod 400 /etc/munge/munge.key
fi
mkdir -p /run/munge /var/log/munge /var/lib/munge
chown munge:munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
# What this script starts it marks ($dir/*.ours), so that tests/slurm/stop.sh ends that and
# nothing else.
if ! munge -n >/dev/null 2>&1; then
    if id munge >/dev/null 2>&1; then
        su -s /bin/sh munge -c munged 2>/dev/null || munged --force
    else
        munged --force
    fi
    touch "$dir/munged.ours"
fi

host=$(hostname -s)
cpus=$(nproc)
conf="$dir/slurm.conf"
cat > "$conf" <<EOF
ClusterName=waamtwin
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$conf"

running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }
running "$dir/slurmctld.pid" || { slurmctld -f "$conf" && touch "$dir/slurmctld.ours"; }
running "$dir/slurmd.pid" || { slurmd -f "$conf" && touch "$dir/slurmd.ours"; }

for _ in $(seq 1 60); do
    state=$(sinfo -h -N -o %t 2>/dev/null | head -1 || true)
    case "$state" in
        idle|mix|alloc) echo "$conf"; exit 0 ;;
        down*|drain*) scontrol update NodeName="$host" State=RESUME >/dev/null 2>&1 || true ;;
    esac
    sleep 1
done
echo "the Slurm node did not come up (state '${state:-none}'); logs in $dir/log" >&2
exit 1
