#!/bin/sh
# run-fuzzer.sh HARNESS SEED_CORPUS [libFuzzer options]: the suite's fuzz
# test. Runs HARNESS from the committed seeds for a fixed number of inputs
# with a fixed seed (the same inputs on every run, about 20 s); new inputs
# go to a scratch corpus beside the harness (the seeds are never written),
# a crash to fuzz-artifacts/ there, and fails the test. Extra options
# override these (docs/FUZZING.md: the long run).
set -eu
harness=$1 seeds=$2
shift 2
dir=$(dirname "$harness")/$(basename "$harness")-run
rm -rf "$dir/corpus"
mkdir -p "$dir/corpus" "$dir/artifacts"
exec "$harness" "$dir/corpus" "$seeds" -seed=1 -runs=${FUZZ_RUNS:-20000} \
  -max_total_time=60 -timeout=10 -rss_limit_mb=2048 -max_len=8192 \
  -artifact_prefix="$dir/artifacts/" -print_final_stats=1 "$@"
