#!/usr/bin/env bash
# A real Slurm test (issue 5): installs Debian's slurm-wlm and munge if
# missing, starts a single-node cluster on localhost (slurmctld + slurmd, as
# root), submits the job array that `remembrane sweep --emit-slurm` prints
# for a tiny sweep (2 conditions × 2 κ × 1 repeat of the bundled sphere
# scene, 60 iterations each, 2 array tasks), waits for it, and checks that
# `remembrane collect` sees every run; then a campaign (a sweep with a shared
# phase: the phase job, then the array after it with --dependency=afterok)
# and checks the same. Stops the cluster on exit.
#
# Usage: tests/slurm.sh [REMEMBRANE_BINARY]  (default: target/debug/remembrane,
# the binary `cargo test` builds; .ci/run calls this after `cargo test`).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
bin=$(realpath "${1:-target/debug/remembrane}")
[ -x "$bin" ] || { echo "slurm test: no binary at $bin (run cargo test or cargo build first)" >&2; exit 1; }
work=$(mktemp -d /tmp/remembrane-slurm.XXXXXX)
state="$work/cluster"

start_cluster() {
  mkdir -p "$state"/{spool/ctld,spool/d,log,run} /etc/slurm /run/munge /var/lib/munge /var/log/munge
  if ! command -v slurmctld >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq && apt-get install -y -qq slurm-wlm munge >/dev/null
  fi
  local host cpus mem
  host=$(hostname -s)
  cpus=$(nproc)
  mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 - 1024 ))
  [ -s /etc/munge/munge.key ] || { mkdir -p /etc/munge; dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null; }
  chown -R munge:munge /etc/munge /run/munge /var/lib/munge /var/log/munge 2>/dev/null || true
  chmod 400 /etc/munge/munge.key
  pgrep -x munged >/dev/null || su -s /bin/sh munge -c /usr/sbin/munged 2>/dev/null || /usr/sbin/munged --force
  cat > /etc/slurm/slurm.conf <<CONF
ClusterName=local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state/spool/ctld
SlurmdSpoolDir=$state/spool/d
SlurmctldPidFile=$state/run/slurmctld.pid
SlurmdPidFile=$state/run/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  cat > /etc/slurm/cgroup.conf <<CONF
CgroupPlugin=autodetect
IgnoreSystemd=yes
CONF
  slurmctld
  slurmd
  for _ in $(seq 1 30); do
    if sinfo -h -o %T 2>/dev/null | grep -qE "idle|mixed|alloc"; then return 0; fi
    sleep 1
  done
  echo "slurm test: the cluster did not come up" >&2
  tail -5 "$state"/log/*.log >&2 || true
  return 1
}

stop_cluster() {
  for f in "$state/run/slurmd.pid" "$state/run/slurmctld.pid"; do
    [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null || true
  done
}
cleanup() {
  stop_cluster
  sleep 1
  rm -rf "$work"
}
trap cleanup EXIT

# Waits until the jobs (comma-separated ids) have left the queue, at most 300 s.
wait_for_jobs() {
  for _ in $(seq 1 300); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 1
  done
  echo "slurm test: jobs $1 still queued after 300 s" >&2; squeue >&2; exit 1
}

# Live daemons only (stopped ones may linger as zombies where PID 1 does
# not reap).
if ps -C slurmctld,slurmd -o stat= 2>/dev/null | grep -qv '^Z'; then
  echo "slurm test: slurmctld/slurmd already run on this machine; stop them first (this test starts its own)" >&2
  exit 1
fi

start_cluster
echo "slurm test: cluster up: $(sinfo -h | head -1)"

cat > "$work/mini.ron" <<SWEEP
Sweep(
    name: "slurm_mini",
    scene: "$root/scenes/sphere.ron",
    repeats: 1,
    seed: 11,
    conditions: [
        (name: "short", set: [Iterations(60)]),
        (name: "long", set: [Iterations(80)]),
    ],
    grid: [(name: "kappa", values: [Kappa(1.0), Kappa(2.0)])],
)
SWEEP
out="$work/out"
"$bin" sweep "$work/mini.ron" --out "$out" --emit-slurm --tasks 2 > "$work/array.sbatch"
grep -q -- '--array=0-1' "$work/array.sbatch"
job=$(sbatch --parsable "$work/array.sbatch")
echo "slurm test: submitted array job $job"
wait_for_jobs "$job"
for f in "$out"/slurm-*.out; do [ -f "$f" ] && { echo "--- $f"; cat "$f"; }; done
report=$("$bin" collect "$out" --x time --y energy_total)
echo "$report"
echo "$report" | grep -q "^4 of 4 runs collected$" || { echo "slurm test: collect did not see every run" >&2; exit 1; }
[ -f "$out/collect.csv" ] && [ -f "$out/fig5f.png" ]
echo "slurm test: array passed"

# A campaign: a sweep with a shared phase. The emitted script submits the
# phase as one job and the run array after it (--dependency=afterok).
cat > "$work/campaign.ron" <<SWEEP
Sweep(
    name: "slurm_campaign",
    scene: "$root/scenes/sphere.ron",
    seed: 13,
    phases: [(name: "relax", scene: "$root/scenes/sphere.ron", iterations: 60, set: [Kappa(3.0)])],
    conditions: [
        (name: "cont", from_phase: "relax", set: [Iterations(40)]),
        (name: "fresh", set: [Iterations(40)]),
    ],
    grid: [(name: "kappa", values: [Kappa(1.0), Kappa(2.0)])],
)
SWEEP
cout="$work/campaign"
"$bin" sweep "$work/campaign.ron" --out "$cout" --emit-slurm --tasks 2 > "$work/campaign.sh"
grep -q -- '--dependency=afterok' "$work/campaign.sh"
submitted=$(bash "$work/campaign.sh")
echo "slurm test: $submitted"
phase_job=$(echo "$submitted" | sed -n 's/^submitted phases job \([0-9]*\) and run array \([0-9]*\).*/\1/p')
array_job=$(echo "$submitted" | sed -n 's/^submitted phases job \([0-9]*\) and run array \([0-9]*\).*/\2/p')
[ -n "$phase_job" ] && [ -n "$array_job" ] || { echo "slurm test: no job ids in: $submitted" >&2; exit 1; }
wait_for_jobs "$phase_job,$array_job"
for f in "$cout"/slurm-*.out; do [ -f "$f" ] && { echo "--- $f"; cat "$f"; }; done
[ -f "$cout/phases/relax/state.json" ] || { echo "slurm test: the shared phase did not run" >&2; exit 1; }
# The array ran after the phase: every run directory is newer than the phase's summary.
for s in "$cout"/runs/*/*/rep00/summary.json; do
  [ "$s" -nt "$cout/phases/relax/summary.json" ] || { echo "slurm test: $s is older than the phase" >&2; exit 1; }
done
report=$("$bin" collect "$cout" --x time --y energy_total)
echo "$report"
echo "$report" | grep -q "^4 of 4 runs collected$" || { echo "slurm test: collect did not see every campaign run" >&2; exit 1; }
echo "slurm test: campaign passed"
echo "slurm test: passed"
