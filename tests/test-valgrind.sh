#!/usr/bin/env bash
# The whole chain under valgrind's memcheck: no invalid access, no
# uninitialised value used, nothing definitely or indirectly lost (GLib's
# and GStreamer's one-off type and plugin allocations are "still
# reachable", not lost). Prints TAP. About 1.5 minutes.
#   1. gst-launch-1.0 runs the chain (and sonartrack) on two pings.
#   2. tests/stability-cycles takes one pipeline from NULL to PLAYING and
#      back SONAR_VALGRIND_CYCLES times (default 6; to EOS, or stopped
#      mid-run), the elements' thread pools included.
set -u
echo "1..2"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
export G_SLICE=always-malloc G_DEBUG=gc-friendly
export GST_REGISTRY_1_0="${GST_REGISTRY_1_0:-$(mktemp -u)}"
build="${SONAR_BUILD_DIR:-$(dirname "$0")/../build}"
failed=0

# memcheck N DESCRIPTION KINDS COMMAND...: runs COMMAND under memcheck as
# test N; the leak KINDS are errors.
memcheck () {
  local n=$1 what=$2 kinds=$3 status summary
  shift 3
  valgrind --leak-check=full --errors-for-leak-kinds="$kinds" \
    --suppressions="$(dirname "$0")/valgrind.supp" \
    --error-exitcode=3 --num-callers=30 "$@" >"$log" 2>&1
  status=$?
  summary=$(grep -E "ERROR SUMMARY|(definitely|indirectly|possibly) lost:" "$log" \
    | sed 's/^==[0-9]*== //')
  echo "$summary" | sed 's/^/# /'
  if [ $status -eq 0 ]; then
    echo "ok $n - $what clean under memcheck"
  else
    grep -B2 -A20 -E "Invalid|uninitialised|(definitely|indirectly|possibly) lost in" \
      "$log" | head -60 | sed 's/^/# /'
    tail -5 "$log" | sed 's/^/# /'
    echo "not ok $n - $what under memcheck (valgrind exit $status)"
    failed=1
  fi
}

# 181 directions: the imager's coarse-to-fine path (31 directions, in
# stability-cycles, image every direction in full).
memcheck 1 "whole chain" definite,indirect \
  gst-launch-1.0 -q sonarsrc num-buffers=2 max-range=2.0 \
  ! dopplerbank velocity-min=-0.3 velocity-max=0.3 velocity-step=0.05 \
  ! mimobeamform range-max=2.0 threads=2 \
  ! wardcluster ! velocityest threads=2 ! sonartrack ! fakesink

# The program ends with gst_deinit (), so even "possibly lost" counts: a
# worker pool leaked with its threads shows only as that.
memcheck 2 "${SONAR_VALGRIND_CYCLES:-6} NULL-PLAYING-NULL cycles" \
  definite,indirect,possible \
  "$build/tests/stability-cycles" "${SONAR_VALGRIND_CYCLES:-6}"

exit $failed
