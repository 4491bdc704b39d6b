#!/usr/bin/env bash
# Several sensors, one host: two sonarsrc (two sensors at different places
# in one world), each tagged with its frame id (sonarsrc frame-id, carried
# by the set-up event to every detection's "frame_id"), each through its
# own chain; a funnel gathers both chains' JSON lines on stdout.
#   pipelines/two-sensors.sh [left.json right.json [pings]]
# Frame ids: SONAR_FRAME_IDS="sonar_left sonar_right" (the default).
set -euo pipefail
scenes="$(cd "$(dirname "$0")" && pwd)/scenes"
left="$(realpath "${1:-$scenes/two-sensors-left.json}")"
right="$(realpath "${2:-$scenes/two-sensors-right.json}")"
pings="${3:-3}"
read -r left_id right_id <<< "${SONAR_FRAME_IDS:-sonar_left sonar_right}"
. "$(dirname "$0")/../tools/env.sh"
chain="dopplerbank velocity-min=-1.5 velocity-max=1.5 velocity-step=0.05 \
  ! mimobeamform ! wardcluster ! velocityest"
# shellcheck disable=SC2086
gst-launch-1.0 -q funnel name=results ! fdsink \
  sonarsrc frame-id="$left_id" scene-file="$left" num-buffers="$pings" \
  ! $chain ! results. \
  sonarsrc frame-id="$right_id" scene-file="$right" num-buffers="$pings" \
  ! $chain ! results.
