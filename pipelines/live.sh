#!/usr/bin/env bash
# A live robot's chain with gst-launch-1.0: the source pings at its rate in
# its own thread, the leaky queue keeps only the newest ping (the chain
# drops whole pings when it falls behind: dopplerbank reports them), one
# JSON line per ping on stdout as soon as it is ready. Ctrl-C stops it.
#   pipelines/live.sh [sonarsrc properties...]      e.g. pipelines/live.sh scene=fig9
# An application takes the results from an appsink: pipelines/live-robot.py.
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
gst-launch-1.0 -q -e sonarsrc is-live=true "$@" \
  ! queue leaky=downstream max-size-buffers=1 \
  ! dopplerbank ! mimobeamform ! wardcluster ! velocityest ! fdsink sync=false
