#!/usr/bin/env bash
# The scale-out path tested on a real Slurm: installs slurm-wlm and munge
# (Debian/Ubuntu, as root), starts a one-node cluster on this machine
# (munged if it is not running, slurmctld and slurmd with a generated
# slurm.conf for this machine's CPUs and memory, on ports 6917-6918), submits
# scripts/slurm/render.sh for a small scene, waits for the merge, and checks
# that the merged image is bit-identical to `caustix render` of the same
# scene. Stops the daemons it started, by their process ids, however it ends.
# Elsewhere (not root, not Debian/Ubuntu) it says why it skips, and succeeds.
# Expects target/release/caustix built (./dev.sh test builds it first).
set -euo pipefail
cd "$(dirname "$0")/.."

skip() { echo "slurm-test: skipped: $*" >&2; exit 0; }
[ "$(id -u)" -eq 0 ] || skip "needs root to install and start Slurm's daemons"
command -v dpkg >/dev/null 2>&1 && command -v apt-get >/dev/null 2>&1 || skip "not a Debian/Ubuntu system"
caustix=$PWD/target/release/caustix
[ -x "$caustix" ] || { echo "slurm-test: build caustix first (cargo build --release)" >&2; exit 1; }

missing=()
for pkg in slurm-wlm munge; do dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg"); done
if ((${#missing[@]})); then
    echo "slurm-test: installing ${missing[*]}" >&2
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

work=$(mktemp -d /tmp/caustix-slurm.XXXXXX)
pids=()
cleanup() {
    local status=$?
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
    done
    if [ "$status" -ne 0 ]; then
        echo "slurm-test: FAILED; logs:" >&2
        tail -n 20 "$work"/*.log "$work"/frame.exr.parts/*.log 2>/dev/null >&2 || true
    fi
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT

# munge authenticates Slurm's messages; start it unless it already runs.
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    [ -s /etc/munge/munge.key ] || { mungekey --create 2>/dev/null || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null; }
    chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
    mkdir -p /run/munge && chown munge:munge /run/munge
    runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/munged.pid
    pids+=("$(cat /run/munge/munged.pid)")
fi

host=$(hostname -s)
memory=$(awk '/MemTotal/ {print int($2 / 1024)}' /proc/meminfo)
mkdir -p "$work/state" "$work/spool"
export SLURM_CONF=$work/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=caustix-test
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
SlurmctldPort=6917
SlurmdPort=6918
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host CPUs=$(nproc) RealMemory=$memory State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for daemon in slurmctld slurmd; do
    for _ in $(seq 50); do [ -s "$work/$daemon.pid" ] && break; sleep 0.1; done
    [ -s "$work/$daemon.pid" ] || { echo "slurm-test: $daemon did not start" >&2; exit 1; }
    pids+=("$(cat "$work/$daemon.pid")")
done
for _ in $(seq 60); do sinfo -h -o %T 2>/dev/null | grep -qx idle && break; sleep 1; done
sinfo -h -o %T | grep -qx idle || { echo "slurm-test: the node never became idle: $(sinfo -h)" >&2; exit 1; }
echo "slurm-test: one-node cluster up on $host ($(nproc) CPUs), $(slurmctld -V)" >&2

scene=scenes/cornell.toml
settings=(--width 64 --height 48 --spp 2 --photons 20000 --caustic-photons 20000)
CAUSTIX=$caustix CPUS=1 scripts/slurm/render.sh "$scene" 4 "$work/frame.exr" "${settings[@]}" >&2
for _ in $(seq 300); do
    [ -z "$(squeue -h 2>/dev/null)" ] && break
    sleep 1
done
[ -z "$(squeue -h)" ] || { echo "slurm-test: jobs still queued after 300 s: $(squeue -h)" >&2; exit 1; }
[ -f "$work/frame.exr" ] || { echo "slurm-test: the merge job wrote no image" >&2; exit 1; }
"$caustix" render "$scene" "${settings[@]}" -o "$work/plain.exr" 2>/dev/null
# The same pixels bit for bit (the EXR files' bytes may differ in block order).
"$caustix" compare "$work/frame.exr" "$work/plain.exr" | tee "$work/compare.txt" >&2
grep -q "^identical yes" "$work/compare.txt" || { echo "slurm-test: the merged image differs" >&2; exit 1; }
echo "slurm-test: photons + 4 tiles + merge on Slurm: bit-identical to one render" >&2
