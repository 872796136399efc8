#!/usr/bin/env bash
# Coverage-guided fuzzing of errmap's readers with AFL++ (cargo-afl's AFL++, stable Rust).
#
#   fuzz/run.sh SECONDS TARGET...     TARGET: decoder error_table session_table
#                                     machine_model plan vol_model vol_plan line_table, or all
#
#   fuzz/run.sh 15 all       CI's bounded run: 8 x 15 s = 120 s of fuzzing
#   fuzz/run.sh 600 all      the longer campaign (80 min; one target: fuzz/run.sh 3600 plan)
#
# Installs cargo-afl and builds AFL++ when they are missing, then builds ONE binary for
# every target (`afl TARGET`) in which only errmap's own crates are instrumented: the
# RUSTC_WRAPPER fuzz/rustc-afl.sh adds the SanitizerCoverage flags of `cargo afl build`
# to errmap, errmap-drivers and errmap-fuzz and links AFL++'s runtime, while polars and
# the other dependencies are built as `cargo build` builds them, in the workspace's
# target/ (or $CARGO_TARGET_DIR), where `cargo test` has built them already. Our crates
# get `codegen-units=1` (cargo-afl's work-around for link errors), which gives their
# instrumented rlibs names of their own: `cargo test` at the root and this script
# alternate without rebuilding each other's crates. (`cargo afl build` instruments and
# optimises polars too: 73 minutes here.) Measured costs: docs/robustness-log.md, "Fuzzing".
#
# Each target then runs for SECONDS seconds from fuzz/corpus/TARGET (AFL's findings under
# fuzz/out/TARGET). Exits 1 when AFL saved a crash, listing the files: replay one with
# `cargo run --manifest-path fuzz/Cargo.toml --bin replay -- TARGET FILE`, fix it, and
# add the file to fuzz/regressions/TARGET/ (tests/it/robust_io.rs replays that folder on
# every `cargo test`).
set -euo pipefail
# The target dir: $CARGO_TARGET_DIR (relative to where run.sh was called) or the root's.
tdir=$(realpath -m "${CARGO_TARGET_DIR:-$(dirname "$0")/../target}")
self=$(realpath "$0")
cd "$(dirname "$self")"
[ $# -ge 2 ] || { sed -n '4,8p' "$self" | sed 's/^# *//'; exit 2; }
secs=$1
shift
all=(decoder error_table session_table machine_model plan vol_model vol_plan line_table import_session controller_table)
targets=("$@")
[ "${targets[0]}" = all ] && targets=("${all[@]}")

if ! command -v cargo-afl >/dev/null; then
    echo "== cargo install cargo-afl"
    cargo install cargo-afl --locked --version 0.18.2 --quiet
fi
# Builds AFL++ once per toolchain; refuses (and we go on) when it is built already.
cargo afl config --build >/dev/null 2>&1 || true

# AFL++'s runtime, where cargo-afl keeps it: per rustc (version and short commit) and
# cargo-afl version.
rustc_dir=$(rustc -vV | awk '/^release:/ {r = $2} /^commit-hash:/ {h = substr($2, 1, 7)}
    END {print "rustc-" r "-" h}')
afl_version=$(cargo afl --version | awk '{print $2}')
export AFL_RT="${XDG_DATA_HOME:-$HOME/.local/share}/afl.rs/$rustc_dir/afl.rs-$afl_version/afl-llvm/afl-compiler-rt.o"
[ -f "$AFL_RT" ] || { echo "fuzz/run.sh: no AFL++ runtime at $AFL_RT (cargo afl config --build)"; exit 1; }

ours=()
for p in errmap errmap-drivers errmap-fuzz; do
    ours+=(--config "profile.dev.package.$p.codegen-units=1" --config "profile.dev.package.$p.opt-level=1")
done
echo "== build: errmap's crates instrumented, the dependencies shared with $tdir/debug"
CARGO_TARGET_DIR=$tdir RUSTC_WRAPPER=$PWD/rustc-afl.sh \
    cargo build --quiet "${ours[@]}" --features afl --bin afl
bin=$tdir/debug/afl

export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
export AFL_BENCH_UNTIL_CRASH=1 AFL_NO_AFFINITY=1
crashes=0
for t in "${targets[@]}"; do
    out=out/$t
    rm -rf "$out"
    mkdir -p out   # absent on a fresh clone (git ignores it)
    echo "== afl-fuzz $t for $secs s"
    cargo afl fuzz -V "$secs" -i "corpus/$t" -o "$out" -- "$bin" "$t" >"$out.log" 2>&1 || {
        echo "afl-fuzz $t failed:"
        tail -n 20 "$out.log"
        exit 1
    }
    stats=$out/default/fuzzer_stats
    echo "   $(grep -E '^(execs_done|execs_per_sec|corpus_count|edges_found|saved_crashes|saved_hangs) ' "$stats" | awk '{printf "%s=%s ", $1, $3}')"
    found=$(find "$out/default/crashes" -type f ! -name README.txt 2>/dev/null | wc -l)
    if [ "$found" -gt 0 ]; then
        echo "   $found crash(es) in $t:"
        find "$out/default/crashes" -type f ! -name README.txt | sed 's/^/     fuzz\//'
        crashes=$((crashes + found))
    fi
done
[ "$crashes" -eq 0 ] || { echo "== $crashes crash(es): see above"; exit 1; }
echo "== no crash"
