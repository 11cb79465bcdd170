#!/usr/bin/env bash
# Builds the shipped static library, libweft.a: the runtime alone (no_std, no allocation),
# panic = "abort", fat LTO and one codegen unit (profile "ship" in Cargo.toml). Progress goes to
# stderr; the last line on stdout is the absolute path of the produced .a.
#
#   scripts/build-staticlib.sh [extra cargo args, e.g. --target aarch64-unknown-linux-gnu]
#
# Why `cargo rustc --crate-type staticlib` and not `cargo build --release`: with
# crate-type = ["staticlib", "rlib"] cargo skips LTO altogether; building the staticlib alone
# lets `lto = true` apply, which also drops the unused unwinding machinery of `core`.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo="${CARGO:-cargo}"
target=""
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
    case "${args[$i]}" in
        --target) target="${args[$((i + 1))]:-}" ;;
        --target=*) target="${args[$i]#--target=}" ;;
    esac
done
"$cargo" rustc --profile ship --lib --no-default-features --crate-type staticlib "$@" >&2
dir="${CARGO_TARGET_DIR:-target}"
case "$dir" in
    /*) ;;
    *) dir="$(pwd)/$dir" ;;
esac
if [ -n "$target" ]; then
    dir="$dir/$target"
fi
lib="$dir/ship/libweft.a"
test -f "$lib" || { echo "build-staticlib: $lib was not produced" >&2; exit 1; }
echo "$lib"
