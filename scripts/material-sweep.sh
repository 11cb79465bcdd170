#!/bin/sh
# How weft-bench's CG count grows with the mesh, by material (docs/PERFORMANCE.md, "The CG
# count by material"):
#   scripts/material-sweep.sh [WEFT_BENCH_BINARY]
# weft-bench's scene (tolerance 1e-3) with the bundled `stripes` cell and each cell of
# examples/bench_cells/, at 21/41/81/161 vertices per side (200/100/40/12 timed steps), four
# trajectories each (the wind turned 0, ±0.02, +0.04 rad). Each line: the cell, the grid, then
# the medians over the trajectories of the first solve's CG iterations per substep, all CG
# iterations per step, µs per step, the worst edge strain, and the steps redone.
set -eu
cd "$(dirname "$0")/.."
bin=${1:-target/release/weft-bench}
for cell in cells/stripes.toml examples/bench_cells/*.toml; do
    for grid in 21 41 81 161; do
        case $grid in
        21) steps=200 ;;
        41) steps=100 ;;
        81) steps=40 ;;
        *) steps=12 ;;
        esac
        "$bin" --grid "$grid" --steps "$steps" --tolerance 1e-3 --trajectories 4 --cell "$cell" \
            --json | python3 -c '
import json, sys
d = json.load(sys.stdin)
print(sys.argv[1], sys.argv[2], round(d["cg_iterations_first_solve"], 1),
      round(d["cg_iterations_mean"], 1), round(d["us_per_step_median"]),
      round(d["worst_edge_strain"], 4), d["steps_redone"])' "$(basename "$cell" .toml)" "$grid"
    done
done
