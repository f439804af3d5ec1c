#!/bin/sh
# Runs every fuzz target in turn, each for SECONDS (default 600), one job at a time:
#   fuzz/run.sh [SECONDS] [TARGET...]
# Needs nightly and cargo-fuzz (`cargo install cargo-fuzz`). New inputs go to fuzz/corpus/TARGET
# (not committed), seeds are read from fuzz/seeds/TARGET, crashes land in fuzz/artifacts/TARGET.
# The last lines of each run (executions, crashes) are kept in fuzz/logs/TARGET.log.
set -eu
cd "$(dirname "$0")"
seconds=${1:-600}
[ $# -gt 0 ] && shift
targets=${*:-room ies ldt obj points}
mkdir -p logs
for target in $targets; do
    mkdir -p "corpus/$target" "artifacts/$target"
    dict=""
    [ -f "dict/$target.dict" ] && dict="-dict=dict/$target.dict"
    echo "== $target: $seconds s"
    status=0
    cargo +nightly fuzz run "$target" "corpus/$target" "seeds/$target" -- \
        -max_total_time="$seconds" -jobs=1 -workers=1 -rss_limit_mb=2048 -timeout=20 \
        -artifact_prefix="artifacts/$target/" -print_final_stats=1 $dict \
        >"logs/$target.log" 2>&1 || status=$?
    grep -E "^(Done|stat::number_of_executed_units|stat::peak_rss_mb)|SUMMARY|panicked|==ERROR" "logs/$target.log" || true
    echo "   exit $status; crashes: $(ls "artifacts/$target" | wc -l)"
done
