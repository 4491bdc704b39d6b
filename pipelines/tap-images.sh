#!/usr/bin/env bash
# Taps the chain: saves the MIMO energyscape and one emitter's image of a
# ping with tee, then draws both (out/tap-mimo.png, out/tap-emitter0.png).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
. "$root/tools/env.sh"
mkdir -p out
gst-launch-1.0 -q sonarsrc scene="${1:-default}" num-buffers=1 \
  ! dopplerbank velocity-min=-1.5 velocity-max=1.5 ! tee name=t \
  t. ! queue ! mimobeamform ! filesink location=out/tap-mimo.es \
  t. ! queue ! mimobeamform emitter=0 ! filesink location=out/tap-emitter0.es
/usr/bin/python3 "$root/tools/plot-energyscape.py" out/tap-mimo.es -o out/tap-mimo.png
/usr/bin/python3 "$root/tools/plot-energyscape.py" out/tap-emitter0.es -o out/tap-emitter0.png
