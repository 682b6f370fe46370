#!/usr/bin/env bash
# Iterations and wall time to equilibrium against the mesh size: the fluid
# red blood cell at v = 0.6 and the fluid oblate at v = 0.8 (A = 553 l̄²,
# κ = 5 Ē), each started from its spheroid directly at 642, 2562, 10242
# and 40962 vertices (h = 1, 1/2, 1/4, 1/8), with plain FIRE and with the
# Sobolev-preconditioned FIRE, to the same force tolerance in physical
# units (1e-3 Ē/l̄ at h = 1, scaled by h² with the vertex areas). The
# oblate is held axisymmetric (`axisymmetric`, docs/minimiser.md).
#
# Every case is scenes/fluid/red_blood_cell.ron with only its membrane
# level, its resolution, its target volume and its method changed. FIRE's
# iteration caps stop it near 10 minutes on the 2-core VM (its per-iteration
# cost measured on 2026-12-06); the Sobolev runs stop by their tolerances.
#
#   bash benches/equilibrium_table.sh [--threads N] [--only sobolev|fire]
#
# prints a Markdown table (and keeps the runs in $OUT, default
# target/equilibrium_table).
set -euo pipefail
cd "$(dirname "$0")/.."
threads=2
only=""
while [ $# -gt 0 ]; do
  case $1 in
    --threads) threads=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    *) echo "usage: $0 [--threads N] [--only sobolev|fire]"; exit 2 ;;
  esac
done
cargo build --release --locked -q
bin=target/release/remembrane
out=${OUT:-target/equilibrium_table}
mkdir -p "$out"
base=scenes/fluid/red_blood_cell.ron
# level, h, FIRE's iteration cap (about 10 minutes)
ladder="3 1.0 20000
4 0.5 60000
5 0.25 120000
6 0.125 25000"
echo "| shape | vertices | method | iterations | stopped by | wall s | E_b/8πκ |"
echo "|---|---:|---|---:|---|---:|---:|"
for shape in rbc:0.6 oblate:0.8; do
  name=${shape%%:*}
  v=${shape##*:}
  while read -r level h cap; do
    for method in fire sobolev; do
      [ -n "$only" ] && [ "$only" != "$method" ] && continue
      scene="$out/${name}_l${level}_${method}.ron"
      sed -e "s/level: 3,/level: $level,/" \
          -e "s/volume: Reduced(0.6)/volume: Reduced($v)/" \
          -e "s/    model: Fluid(),/    resolution: EdgeLength($h),\n    model: Fluid(),/" \
          "$base" >"$scene"
      # The oblate at v = 0.8 is a saddle among all shapes (the diagram's
      # oblate branch): held axisymmetric about z, by both methods.
      if [ "$name" = oblate ]; then
        sed -i -e "s/        method: Minimise(/        method: Minimise(\n            axisymmetric: (0.0, 0.0, 1.0),/" "$scene"
      fi
      iterations=60000
      if [ "$method" = fire ]; then
        sed -i -e "s/            preconditioner: Sobolev(),//" "$scene"
        iterations=$cap
      fi
      run="$out/${name}_l${level}_${method}"
      "$bin" run "$scene" --out "$run" --overwrite --threads "$threads" --quiet \
        --iterations "$iterations" --frames 1 >/dev/null 2>&1 || true
      python3 - "$run/summary.json" "$name" "$method" <<'EOF'
import json, math, sys
s = json.load(open(sys.argv[1]))
m = s.get("minimiser") or {}
eb = next(e["energy"] for e in s["energies"] if e["term"] == "bending")
print(f"| {sys.argv[2]} | {s['vertices']} | {sys.argv[3]} | {s['iterations']} | "
      f"{m.get('stopped_by') or 'cap'} | {s['wall_time_s']:.1f} | {eb / (8 * math.pi * 5):.5f} |")
EOF
    done
  done <<<"$ladder"
done
