#!/bin/sh
# Times weft-bench binaries in turn, so they share the machine's load, for the README's tables:
#   scripts/bench-rounds.sh OLD_BINARY NEW_BINARY [...]
# Per grid: 3 rounds at 21/41/81/161 vertices per side (200/100/30/10 timed steps),
# tolerance 1e-3; each line is one run's median µs/step, CG iterations, converged share,
# redone steps and worst edge strain. Take the median over the rounds; compare as ratios.
set -eu
cd "$(dirname "$0")/.."
for grid in 21 41 81 161; do
    case $grid in
    21) steps=200 rounds=3 ;;
    41) steps=100 rounds=3 ;;
    81) steps=30 rounds=3 ;;
    *) steps=10 rounds=3 ;;
    esac
    round=1
    while [ "$round" -le "$rounds" ]; do
        for bin in "$@"; do
            line=$("$bin" --grid "$grid" --tolerance 1e-3 --steps "$steps" |
                grep -E 'median|CG iterations|converged|redone|strain' | tr -s ' ' | tr '\n' '|')
            echo "$grid $round $bin $line"
        done
        round=$((round + 1))
    done
done
