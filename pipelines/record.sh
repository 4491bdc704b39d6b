#!/usr/bin/env bash
# Saves simulated pings as a 32-channel WAV file, with the waveforms file
# that describes their emissions (the default waveforms of sonarsrc).
#   pipelines/record.sh fig10 12
set -euo pipefail
cd "$(dirname "$0")/.." && . tools/env.sh
mkdir -p out
build/tools/sonar-waveforms -o out/waveforms.json
gst-launch-1.0 -q sonarsrc scene="${1:-default}" num-buffers="${2:-3}" \
  ! wavenc ! filesink location="out/${1:-default}.wav"
echo "out/${1:-default}.wav: pings of 17262 samples (sonarsrc's default window)"
