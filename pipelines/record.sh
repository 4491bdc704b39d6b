#!/usr/bin/env bash
# Records a session: simulated pings as a 32-channel WAV file, and the
# sensor description of what sonarsrc emitted (array, waveforms, ping
# timing) beside it. pipelines/recording.sh replays the pair.
#   pipelines/record.sh fig10 12
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
mkdir -p out
scene="${1:-default}"
gst-launch-1.0 -q sonarsrc scene="$scene" num-buffers="${2:-3}" \
    write-sensor-file="out/$scene.sensor.json" \
  ! wavenc ! filesink location="out/$scene.wav"
echo "out/$scene.wav and its sensor description out/$scene.sensor.json"
