#!/usr/bin/env bash
# Coverage-guided fuzzing of errmap's readers with AFL++ (cargo-afl, stable Rust).
#
#   fuzz/run.sh SECONDS TARGET...     TARGET: decoder error_table session_table
#                                     machine_model plan vol_model vol_plan line_table, or all
#
# Installs cargo-afl and builds AFL++ when they are missing, builds the instrumented
# harness in fuzz/target (the decoder alone builds without polars: `fuzz/run.sh 60 decoder`
# is CI's bounded run), then runs each target for SECONDS seconds from fuzz/corpus/TARGET
# (AFL's findings under fuzz/out/TARGET). Exits 1 when AFL saved a crash, listing the
# files: replay one with `cargo run --manifest-path fuzz/Cargo.toml --bin replay -- TARGET
# FILE`, fix it, and add the file to fuzz/regressions/TARGET/ (tests/it/robust_io.rs
# replays that folder on every `cargo test`).
set -euo pipefail
cd "$(dirname "$0")"
[ $# -ge 2 ] || { sed -n '3,4p' "$0" | sed 's/^# *//'; exit 2; }
secs=$1
shift
all=(decoder error_table session_table machine_model plan vol_model vol_plan line_table)
targets=("$@")
[ "${targets[0]}" = all ] && targets=("${all[@]}")

if ! command -v cargo-afl >/dev/null; then
    echo "== cargo install cargo-afl"
    cargo install cargo-afl --locked --version 0.18.2 --quiet
fi
# Builds AFL++ once per toolchain; refuses (and we go on) when it is built already.
cargo afl config --build >/dev/null 2>&1 || true

tdir=${CARGO_TARGET_DIR:-target}
export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
export AFL_BENCH_UNTIL_CRASH=1 AFL_NO_AFFINITY=1
if [ "${targets[*]}" = decoder ]; then
    echo "== cargo afl build (decoder only, no polars)"
    cargo afl build --quiet --no-default-features --features afl --bin afl_decoder
    bins=("$tdir/debug/afl_decoder")
else
    echo "== cargo afl build (every target)"
    cargo afl build --quiet --features afl --bin afl
    bins=()
    for t in "${targets[@]}"; do bins+=("$tdir/debug/afl $t"); done
fi

crashes=0
for i in "${!targets[@]}"; do
    t=${targets[$i]}
    out=out/$t
    rm -rf "$out"
    mkdir -p out   # absent on a fresh clone (git ignores it)
    echo "== afl-fuzz $t for $secs s"
    # shellcheck disable=SC2086 # the binary and its argument
    cargo afl fuzz -V "$secs" -i "corpus/$t" -o "$out" -- ${bins[$i]} >"$out.log" 2>&1 || {
        echo "afl-fuzz $t failed:"
        tail -n 20 "$out.log"
        exit 1
    }
    stats=$out/default/fuzzer_stats
    echo "   $(grep -E '^(execs_done|execs_per_sec|corpus_count|saved_crashes|saved_hangs) ' "$stats" | awk '{printf "%s=%s ", $1, $3}')"
    found=$(find "$out/default/crashes" -type f ! -name README.txt 2>/dev/null | wc -l)
    if [ "$found" -gt 0 ]; then
        echo "   $found crash(es) in $t:"
        find "$out/default/crashes" -type f ! -name README.txt | sed 's/^/     fuzz\//'
        crashes=$((crashes + found))
    fi
done
[ "$crashes" -eq 0 ] || { echo "== $crashes crash(es): see above"; exit 1; }
echo "== no crash"
