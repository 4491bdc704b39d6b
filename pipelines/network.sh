#!/usr/bin/env bash
# The sensor and the processing as two processes, on one machine or two,
# over TCP: GStreamer's data protocol (gdppay, gdpdepay) carries the
# recording's caps and the sonar-setup event with the samples, so the
# processing side needs no sensor file. Start the processing side first:
#   pipelines/network.sh processing 5000 > detections.jsonl
#   pipelines/network.sh sensor 127.0.0.1 5000 12     # 12 pings sent, then EOS
# (a live sensor loses the pings it records while the link is busy: their
# indices are gaps in the JSON's "ping", and dopplerbank warns of them)
# SONAR_BANK sets dopplerbank's bank on the processing side (default: the
# element's -7..7 m/s), e.g. SONAR_BANK="velocity-min=-1.5 velocity-max=1.5".
# SONAR_LIVE=false sends pings as fast as the processing takes them
# instead of at the sensor's rate (a live sensor loses the pings it records
# while the link is busy, as the real one does).
set -euo pipefail
. "$(dirname "$0")/../tools/env.sh"
case "${1:-}" in
  processing)
    # shellcheck disable=SC2086 # SONAR_BANK is a list of properties
    exec gst-launch-1.0 -q tcpserversrc host=0.0.0.0 port="${2:?port}" \
      ! gdpdepay ! dopplerbank ${SONAR_BANK:-} ! mimobeamform ! wardcluster \
      ! velocityest ! fdsink ;;
  sensor)
    exec gst-launch-1.0 -q sonarsrc is-live="${SONAR_LIVE:-true}" \
      num-buffers="${4:-12}" \
      ! gdppay ! tcpclientsink host="${2:?host}" port="${3:?port}" ;;
  *)
    echo "usage: $0 processing PORT | sensor HOST PORT [PINGS]" >&2
    exit 2 ;;
esac
