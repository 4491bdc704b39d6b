#!/usr/bin/env bash
# The whole chain on a preset: one JSON line of detections per ping on stdout.
#   pipelines/velocity.sh fig10 5
set -euo pipefail
cd "$(dirname "$0")/.." && . tools/env.sh
gst-launch-1.0 -q sonarsrc scene="${1:-default}" num-buffers="${2:-3}" \
  ! dopplerbank velocity-min=-1.5 velocity-max=1.5 velocity-step=0.05 \
  ! mimobeamform ! wardcluster ! velocityest ! fdsink
