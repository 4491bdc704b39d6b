#!/usr/bin/env bash
# The whole chain on a recording (a WAV of one channel per microphone, of
# 16-, 24- or 32-bit integers or 32- or 64-bit floats) described by its
# sensor description file
# (docs/FORMATS.md: the array, the emissions, the ping timing), every
# element at its defaults. One JSON line of detections per ping.
#   pipelines/recording.sh out/fig10.wav out/fig10.sensor.json
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
wav="$1"
sensor="${2:-${wav%.wav}.sensor.json}"
gst-launch-1.0 -q filesrc location="$wav" ! wavparse \
  ! dopplerbank sensor-file="$sensor" \
  ! mimobeamform ! wardcluster ! velocityest ! fdsink
