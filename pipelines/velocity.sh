#!/usr/bin/env bash
# The whole chain on a preset: one JSON line of detections per ping on stdout.
# SONAR_BANK sets dopplerbank's bank (default: the element's -7..7 m/s,
# which holds every preset's movers), e.g.
# SONAR_BANK="velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02".
#   pipelines/velocity.sh fig10 5
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
# shellcheck disable=SC2086 # SONAR_BANK is a list of properties
gst-launch-1.0 -q sonarsrc scene="${1:-default}" num-buffers="${2:-3}" \
  ! dopplerbank ${SONAR_BANK:-} \
  ! mimobeamform ! wardcluster ! velocityest ! fdsink
