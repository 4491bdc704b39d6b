#!/usr/bin/env bash
# The whole chain on a WAV recording (one or many pings, one channel per
# microphone). The recording carries no set-up: dopplerbank reads the
# emission waveforms and the array geometry from files (docs/FORMATS.md) and
# needs the samples per ping (PING_LENGTH, default 17262, sonarsrc's).
#   pipelines/recording.sh out/fig10.wav out/waveforms.json
set -euo pipefail
cd "$(dirname "$0")/.." && . tools/env.sh
wav="$1"
waveforms="${2:-out/waveforms.json}"
geometry="${3:-}"
gst-launch-1.0 -q filesrc location="$wav" ! wavparse \
  ! dopplerbank waveforms-file="$waveforms" ping-length="${PING_LENGTH:-17262}" \
      ${geometry:+geometry-file="$geometry"} \
      velocity-min=-1.5 velocity-max=1.5 velocity-step=0.05 \
  ! mimobeamform ! wardcluster ! velocityest ! fdsink
