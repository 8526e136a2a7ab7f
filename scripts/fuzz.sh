#!/usr/bin/env bash
# Fuzzes the yasps compiler for SECONDS (default 120): builds the sanitizer
# build's fuzz target (scripts/sanitize.sh), seeds a corpus from the lit
# tests and the examples' scenes (scripts/fuzz_seeds.py), and runs libFuzzer
# on it. A crash, sanitizer report, leak or input past TIMEOUT seconds
# (default 120) stops the run with a non-zero status and leaves the input in
# $FUZZ_DIR/findings/ (default build-sanitize/fuzz/): make it a lit test
# under test/Regression/. Figures of the run go to $FUZZ_DIR/summary.txt.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${SANITIZE_DIR:-$root/build-sanitize}
seconds=${1:-120}
timeout=${TIMEOUT:-120}
work=${FUZZ_DIR:-$build/fuzz}

bash "$root/scripts/sanitize.sh" --build-only
mkdir -p "$work/corpus" "$work/seeds" "$work/findings"
YASPS_BUILD_DIR=${YASPS_BUILD_DIR:-$root/build} \
  python3 "$root/scripts/fuzz_seeds.py" "$work/seeds"

echo "== fuzz: yasps-fuzz for ${seconds} s ($(ls "$work/seeds" | wc -l) seeds)"
# One worker: the machine's other core keeps the rest of the job moving.
# The corpus grows across runs; the seeds are re-read every time.
set +e
# allow_user_poisoning=0: see test/lit.cfg.py.
ASAN_OPTIONS=${ASAN_OPTIONS:-allow_user_poisoning=0:detect_leaks=1} \
  "$build/bin/yasps-fuzz" "$work/corpus" "$work/seeds" \
  -max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb=4096 \
  -max_len=16384 -print_final_stats=1 -artifact_prefix="$work/findings/" \
  >"$work/log.txt" 2>&1
status=$?
set -e
grep -E "^stat::|^Done|^#[0-9]+.*DONE" "$work/log.txt" >"$work/summary.txt" || true
# Slow units (past 10 s, under the time limit) are kept but are no finding.
findings=$(find "$work/findings" -name 'crash-*' -o -name 'leak-*' \
  -o -name 'timeout-*' -o -name 'oom-*' | wc -l)
echo "fuzz: $(grep -Eo 'number_of_executed_units:[[:space:]]*[0-9]+' "$work/summary.txt" \
  | grep -Eo '[0-9]+$') runs in ${seconds} s, corpus $(ls "$work/corpus" | wc -l)" \
  "inputs, findings: ${findings}, slowest input" \
  "$(grep -Eo 'slowest_unit_time_sec:[[:space:]]*[0-9]+' "$work/summary.txt" | grep -Eo '[0-9]+$') s" \
  | tee -a "$work/summary.txt"
if [ $status -ne 0 ]; then
  echo "fuzz: yasps-fuzz stopped with status $status; the end of its log:" >&2
  tail -40 "$work/log.txt" >&2
  exit $status
fi
