#!/usr/bin/env bash
# The whole chain under valgrind's memcheck: no invalid access, no
# uninitialised value used, nothing definitely lost (GLib's and GStreamer's
# one-off type and plugin allocations are "still reachable", not lost).
# Prints TAP.
set -u
echo "1..1"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
export G_SLICE=always-malloc G_DEBUG=gc-friendly
export GST_REGISTRY_1_0="${GST_REGISTRY_1_0:-$(mktemp -u)}"
valgrind --leak-check=full --errors-for-leak-kinds=definite \
  --error-exitcode=3 --num-callers=30 \
  gst-launch-1.0 -q sonarsrc num-buffers=2 max-range=2.0 \
  ! dopplerbank velocity-min=-0.3 velocity-max=0.3 velocity-step=0.05 \
  ! mimobeamform azimuth-count=31 range-max=2.0 threads=2 \
  ! wardcluster ! velocityest threads=2 ! fakesink >"$log" 2>&1
status=$?
summary=$(grep -E "ERROR SUMMARY|definitely lost:" "$log" | sed 's/^==[0-9]*== //')
echo "$summary" | sed 's/^/# /'
if [ $status -eq 0 ]; then
  echo "ok 1 - whole chain clean under memcheck"
else
  grep -B2 -A20 -E "Invalid|uninitialised|definitely lost in" "$log" | head -60 | sed 's/^/# /'
  echo "not ok 1 - whole chain under memcheck (valgrind exit $status)"
  exit 1
fi
