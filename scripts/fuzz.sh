#!/usr/bin/env bash
# Fuzzes the blob reader and the mesh/world init + step for a fixed budget each, one target after
# the other (the machine has 2 cores). Not part of CI: it needs nightly and takes minutes.
#
#   scripts/fuzz.sh [seconds per target, default 300] [target ...]   (targets: blob world)
#
# Installs cargo-fuzz from crates.io if it is missing. Each target starts from the committed seeds
# (fuzz/seeds/<target>) plus the corpus earlier runs grew (fuzz/corpus/<target>, kept between
# runs, not committed). Prints per target: executions, executions/s, corpus size, coverage, and
# crashes (files under fuzz/artifacts/<target>/). Replay a crash with
#   cargo +nightly fuzz run <target> fuzz/artifacts/<target>/<file>
# and keep it as a regression test by copying it to tests/fuzz-crashes/<target>/<name>
# (tests/fuzz_regressions.rs replays that folder in `cargo test`). Exit status 1 if anything crashed.
set -uo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-300}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(blob world)

if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
  echo "== installing cargo-fuzz"
  cargo install cargo-fuzz --locked || cargo install cargo-fuzz || exit 2
fi

echo "== building the fuzz targets (nightly, sanitizer coverage, debug assertions)"
(cd fuzz && cargo +nightly fuzz build) || exit 2

status=0
summary=()
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
  known=$(mktemp)
  find "fuzz/artifacts/$t" -type f | sort >"$known"
  log="fuzz/artifacts/$t.log"
  echo "== fuzzing '$t' for ${seconds}s (log: $log)"
  # -timeout: a single input running longer than 10 s is a finding too (a hang).
  (cd fuzz && cargo +nightly fuzz run "$t" "corpus/$t" "seeds/$t" -- \
      -max_total_time="$seconds" -max_len=16384 -timeout=10 -rss_limit_mb=4096 \
      -print_final_stats=1) >"$log" 2>&1
  rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*')
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*')
  corpus=$(find "fuzz/corpus/$t" -type f | wc -l)
  new=$(find "fuzz/artifacts/$t" -type f | sort | comm -13 "$known" -)
  rm -f "$known"
  crashes=$(printf '%s' "$new" | grep -c . || true)
  line="$t: ${execs:-?} executions in ${seconds}s (${rate:-?}/s), coverage ${cov:-?} edges / ${ft:-?} features, corpus $corpus inputs, new crashes $crashes (exit $rc)"
  summary+=("$line")
  echo "$line"
  if [ "$rc" -ne 0 ] || [ "$crashes" -ne 0 ]; then
    status=1
    grep -m1 -B2 -A30 -E 'panicked|ERROR: libFuzzer|SUMMARY' "$log" || true
    printf '%s\n' "$new" | sed '/^$/d; s/^/  crash input: /'
  fi
done

echo "== summary"
printf '%s\n' "${summary[@]}"
exit $status
