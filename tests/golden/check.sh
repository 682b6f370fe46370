#!/usr/bin/env bash
# The golden check: runs every standalone bundled scene (a `Scene(...)` file
# under scenes/, except scenes/hard/, whose stability cases tests/integration/hard_cases.rs
# covers, and the refinement ladders, `resolution: Ladder(...)`, which run
# as protocols of their rungs) for 2000 iterations with the scene's seed
# (1000 for the 40962-vertex scenes/scaled/red_blood_cell_l6.ron, below),
# and compares the sha256 of each final.ply with tests/golden/hashes.txt, on every thread count asked.
#
# The 40962-vertex red blood cell took 34 of a pass's 91 CPU-seconds at 2000
# iterations (the test binary, one thread, 2026-12-08); at 1000 it takes 14,
# after 486 remesh events (420 splits, 66 merges; at 500 there were 36
# merges and no split), so the check still covers its remeshing.
#
# Policies:
# - A refactor keeps every hash.
# - A change meant to alter results re-records the hashes in the same commit
#   (`--record`) and says in its message which scenes change and why.
# - A performance change that only reorders floating-point sums may alter
#   bits. Its commit then shows that the energies, area, volume and reduced
#   volume of every golden scene at 2000 iterations agree with the old ones
#   within 1e-9 relative on the scenes without remeshing, and within the
#   run-to-run spread of seeds on the remeshing ones, and re-records.
#
# Usage, from anywhere:
#   bash tests/golden/check.sh [--threads 1,2,3] [--jobs N] [--bin PATH]
#       compare (exit 1 on any difference)
#   bash tests/golden/check.sh --record            re-record hashes.txt (one thread)
# Prints one line per scene and thread count: same / DIFFERENT / failed /
# not recorded. The runs go N at a time (default 2: their bits do not depend
# on the load). `--bin` checks a binary already built instead of building
# the release one: .ci/run passes the one its tests built (the test
# profile, opt-level 2 with debug assertions; floating point is the same at
# any opt-level, so are the hashes). The runs skip the mesh checks a debug
# build makes after every remesh edit (`--no-check-invariants`): the tests
# run them, and here they would take four times the runs' own time. The recorded hashes started from the ones of main at ffaab08
# (the first ten scenes), then every standalone scene was recorded.
set -u
cd "$(dirname "$(readlink -f "$0")")/../.."
hashes=tests/golden/hashes.txt
record=0; threads=1; jobs=2; bin=""
while [ $# -gt 0 ]; do
  case "$1" in
    --record) record=1; shift ;;
    --threads) threads=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    *) echo "usage: $0 [--record] [--threads N[,N...]] [--jobs N] [--bin PATH]"; exit 2 ;;
  esac
done
if [ -z "$bin" ]; then
  cargo build --release --locked -q || { echo "release build fails"; exit 1; }
  bin=target/release/remembrane
fi
[ -x "$bin" ] || { echo "no binary at $bin"; exit 1; }
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
scenes=$(find scenes -name '*.ron' -not -path 'scenes/hard/*' | sort | while read -r f; do
  grep -q '^Scene(' "$f" && ! grep -q '^ *resolution: Ladder' "$f" && echo "$f"
done)
# The sha256 of the scene's final.ply after its iterations on $2 threads,
# or "failed: <last line of stderr>".
iterations() {
  case "$1" in
    scenes/scaled/red_blood_cell_l6.ron) echo 1000 ;;
    *) echo 2000 ;;
  esac
}
run() {
  local out="$t/$(echo "$1" | tr / _).$2"
  if "$bin" run "$1" --out "$out" --iterations "$(iterations "$1")" --frames 1 --threads "$2" --quiet \
      --no-check-invariants >/dev/null 2>"$out.err"; then
    sha256sum "$out/final.ply" | cut -d' ' -f1
  else
    echo "failed: $(tail -1 "$out.err")"
  fi
}
bad=0
if [ $record = 1 ]; then
  : >"$t/new"
  for f in $scenes; do
    h=$(run "$f" 1)
    case "$h" in failed*) echo "$f: $h"; bad=1 ;; *) echo "$f $h" >>"$t/new"; echo "$f recorded" ;; esac
  done
  [ $bad = 0 ] && cp "$t/new" "$hashes"
  exit $bad
fi
# Every run first, $jobs at a time, each writing its hash (or failure) to
# a file; then the verdicts in scene order.
for f in $scenes; do
  for n in ${threads//,/ }; do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n; done
    run "$f" "$n" >"$t/$(echo "$f" | tr / _).$n.hash" &
  done
done
wait
for f in $scenes; do
  want=$(awk -v s="$f" '$1==s {print $2}' "$hashes")
  if [ -z "$want" ]; then echo "$f: not recorded (run with --record)"; bad=1; continue; fi
  for n in ${threads//,/ }; do
    h=$(cat "$t/$(echo "$f" | tr / _).$n.hash")
    case "$h" in
      failed*) echo "$f ($n threads): $h"; bad=1 ;;
      "$want") echo "$f ($n threads): same" ;;
      *) echo "$f ($n threads): DIFFERENT"; bad=1 ;;
    esac
  done
done
for f in $(awk '{print $1}' "$hashes"); do
  [ -f "$f" ] || { echo "$f: recorded, but the scene is gone"; bad=1; }
done
exit $bad
