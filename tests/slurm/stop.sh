#!/usr/bin/env bash
# Stops what tests/slurm/start.sh started under $1 (default /tmp/waamtwin-slurm) and marked as
# its own ($dir/*.ours): slurmd and slurmctld from their pid files, then munged; each waited
# for at most 10 s, then killed. A daemon that was running before start.sh is left alone.
set -uo pipefail
dir=${1:-/tmp/waamtwin-slurm}
stop() {
    local pid=$1
    kill "$pid" 2>/dev/null || return 0
    for _ in $(seq 1 100); do
        kill -0 "$pid" 2>/dev/null || return 0
        sleep 0.1
    done
    kill -KILL "$pid" 2>/dev/null || true
}
for d in slurmd slurmctld; do
    if [ -f "$dir/$d.ours" ] && [ -f "$dir/$d.pid" ]; then
        stop "$(cat "$dir/$d.pid")"
    fi
    rm -f "$dir/$d.ours"
done
if [ -f "$dir/munged.ours" ]; then
    for pid in $(pgrep -x munged); do
        stop "$pid"
    done
    rm -f "$dir/munged.ours"
fi
exit 0
