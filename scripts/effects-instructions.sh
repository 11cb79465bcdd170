#!/bin/sh
# The README's table of what each effect costs: instructions per step of weft-bench at 21×21
# with every effect on, each one off, and none, at equal solver work (`--iterations 10`),
# counted by callgrind (exact, where times on a shared machine swing 2×). Each configuration
# runs 10 and 70 steps; the difference over 60 steps cancels homogenization and world build.
#   scripts/effects-instructions.sh [WEFT_BENCH_BINARY]   (needs valgrind)
set -eu
cd "$(dirname "$0")/.."
bin=${1:-target/release/weft-bench}
[ -x "$bin" ] || cargo build --release --bin weft-bench
out=$(mktemp -d)
all=gravity,bending,damping,pins,collision,wind,warping
count() { # effects steps -> instructions of the whole run
    valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$bin" --grid 21 --iterations 10 \
        --effects "$1" --steps "$2" >"$out/txt" 2>/dev/null
    callgrind_annotate "$out/cg" 2>/dev/null | awk '/PROGRAM TOTALS/ { gsub(",", "", $1); print $1 }'
}
printf '%-20s %14s %14s\n' effects 'M instr/step' 'CG it/step'
for name in all none gravity bending damping pins collision wind warping; do
    case $name in
    all | none) list=$name ;;
    *) list=$(echo "$all" | tr ',' '\n' | grep -v "^$name\$" | paste -sd, -) ;;
    esac
    short=$(count "$list" 10)
    long=$(count "$list" 70)
    iterations=$(grep 'CG iterations' "$out/txt" | awk '{ print $3 }')
    label=$name
    case $name in all | none) ;; *) label="all but $name" ;; esac
    printf '%-20s %14.2f %14s\n' "$label" "$(echo "($long - $short) / 60 / 1000000" | bc -l)" "$iterations"
done
rm -rf "$out"
