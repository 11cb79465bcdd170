#!/usr/bin/env bash
# Miri (undefined-behaviour checker) on the core, in a short configuration. Not part of CI: it
# needs nightly with the `miri` and `rust-src` components; about 20 minutes on 2 cores from cold
# (mostly building the dependencies for Miri), about 4 minutes of interpretation after that.
#
#   scripts/miri.sh
#
# What runs, and why this selection:
# * the sparse-matrix and PCG unit tests (`--lib -- sparse pcg`), on the no_std build;
# * the blob reader through tests/blob.rs: round trips, the layout, and one test per
#   corruption class (the exhaustive every-truncation / every-byte-flip loops are left to
#   native `cargo test`: under Miri they would take hours, and the fuzzer covers them);
# * World init and steps in memory at every alignment (the crate's one `unsafe` block carves
#   typed arrays out of the caller's bytes) and the bad-input regressions (tests/badinput.rs).
#
# `--features libm/force-soft-floats`: libm's default x86_64 sqrt is inline assembly, which Miri
# cannot interpret; the soft-float build computes the same IEEE results in plain Rust.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! cargo +nightly miri --version >/dev/null 2>&1; then
  echo "== installing the miri and rust-src components for nightly"
  rustup component add miri rust-src --toolchain nightly
fi
export MIRIFLAGS="${MIRIFLAGS:-}"
soft=(--features libm/force-soft-floats)

echo "== Miri: sparse matrix and PCG (lib unit tests, no_std build)"
# Skipped: five PCG tests whose dense O(n³) reference solves take 3 to 10+ minutes each
# under Miri; the solver paths they drive (free, pinned, one-direction filters, warm start)
# are also driven by the tests that run here.
cargo +nightly miri test --no-default-features "${soft[@]}" --lib -- sparse pcg \
  --skip random_spd_systems_match_a_dense_solve --skip pinned_vertices_keep_their_values_exactly \
  --skip one_direction_constraints_hold --skip reported_residual_is_the_preconditioned \
  --skip warm_start_from_the_exact_solution

echo "== Miri: blob reader (tests/blob.rs, short selection)"
cargo +nightly miri test "${soft[@]}" --test blob -- \
  crc32_is_the_ieee_crc small_cell_has_the_documented_shape round_trip_is_bit_exact \
  several_cells_round_trip empty_blob_is_valid layout_follows_the_spec header_corruptions \
  misaligned_base_is_rejected section_table_corruptions nonzero_padding_is_rejected \
  name_corruptions value_corruptions mesh_corruptions

echo "== Miri: World memory carving, init and steps (tests/badinput.rs regressions)"
cargo +nightly miri test "${soft[@]}" --test badinput -- \
  world_memory_at_any_alignment a_failed_step_does_not_poison_the_next \
  an_unused_vertex_is_named values_beyond_f32_are_refused_at_init huge_grid_capacity
