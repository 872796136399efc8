#!/usr/bin/env bash
# RUSTC_WRAPPER for fuzz/run.sh: instruments errmap's own crates for AFL++ and nothing else.
#
# Cargo runs `rustc-afl.sh RUSTC ARGS…` for every crate. For errmap, errmap-drivers and
# errmap-fuzz (CARGO_PKG_NAME; not their build scripts) it adds what `cargo afl build`
# puts in RUSTFLAGS for every crate: SanitizerCoverage (edges and comparisons, the
# feedback AFL++ needs) and `--cfg fuzzing`; a binary of errmap-fuzz also links AFL++'s
# runtime ($AFL_RT, set by run.sh). The dependencies (polars above all) are built as a
# plain `cargo build` builds them, so the build reuses the workspace's own target/debug
# artifacts: the instrumented crates get other file names than the workspace's because
# run.sh builds them with `codegen-units=1` (cargo-afl's work-around for link errors),
# which cargo hashes into their names (a wrapper alone is not part of cargo's hash).
set -euo pipefail
rustc=$1
shift
case "${CARGO_PKG_NAME:-}:${CARGO_CRATE_NAME:-}" in
    *:build_script_*) ;;
    errmap:* | errmap-drivers:* | errmap-fuzz:*)
        flags=(
            -C passes=sancov-module
            -C llvm-args=-sanitizer-coverage-level=3
            -C llvm-args=-sanitizer-coverage-trace-pc-guard
            -C llvm-args=-sanitizer-coverage-prune-blocks=0
            -C llvm-args=-sanitizer-coverage-trace-compares
            -C debug-assertions
            -C overflow-checks
            --cfg fuzzing
        )
        if [ "${CARGO_PKG_NAME}" = errmap-fuzz ] && [[ " $* " == *" --crate-type bin "* ]]; then
            : "${AFL_RT:?rustc-afl.sh: AFL_RT (AFL++ runtime object) is not set: run fuzz/run.sh}"
            flags+=(-C "link-arg=$AFL_RT")
        fi
        exec "$rustc" "$@" "${flags[@]}"
        ;;
esac
exec "$rustc" "$@"
