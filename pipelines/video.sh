#!/usr/bin/env bash
# The paper's Fig. 9 world as a labelled video: each ping's energyscape (the
# fan in metres), every detection ringed and labelled with its radial
# velocity (red approaching, green receding or still), the true objects
# ringed in white. The Fig. 9 bank (-7..7 m/s every 0.05 m/s) is the
# elements' default.
#   pipelines/video.sh [pings] [output] [preset] [tracks]
#   pipelines/video.sh                          # 24 pings (2 s) -> out/fig9.mp4
#   pipelines/video.sh 6 'out/fig9-%03d.png'    # PNG frames instead
#   pipelines/video.sh 12 out/last.png          # the last frame alone
# A live window instead of a file: pipelines/video.sh 24 window
# With "tracks" the detections pass through sonartrack first, and sonarviz
# draws its confirmed tracks too: a magenta square with the track's id and
# an arrow of its velocity in the world, to where it goes in 0.5 s:
#   pipelines/video.sh 12 docs/sonarviz-tracks.png fig9 tracks
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
pings="${1:-24}"
output="${2:-out/fig9.mp4}"
case "$output" in
  window) sink="videoconvert ! autovideosink" ;;
  *.png) sink="pngenc ! multifilesink location=$output" ;;
  # I420: the H.264 profile every player decodes (RGB would give 4:4:4).
  *) sink="videoconvert ! video/x-raw,format=I420 ! x264enc ! mp4mux ! filesink location=$output" ;;
esac
[ "$output" = window ] || mkdir -p "$(dirname "$output")"
case "${4:-}" in
  "") results="velocityest" ;;
  tracks) results="velocityest ! sonartrack" ;;
  *) echo "video.sh: the fourth argument is \"tracks\" or nothing, not \"$4\"" >&2; exit 2 ;;
esac
# The image reaches sonarviz through a tee; velocityest's detections (or
# sonartrack's tracks, which carry them on) meet it on sonarviz's
# "detections" pad, paired by ping.
gst-launch-1.0 -q sonarsrc scene="${3:-fig9}" num-buffers="$pings" \
  ! dopplerbank ! mimobeamform ! wardcluster ! tee name=t \
  sonarviz name=viz ! $sink \
  t. ! queue ! viz.sink \
  t. ! queue ! $results ! viz.detections
[ "$output" = window ] || echo "wrote $output"
