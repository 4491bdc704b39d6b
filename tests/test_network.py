#!/usr/bin/python3
"""Across processes: the sensor side (sonarsrc, gdppay, tcpclientsink) and
the processing side (tcpserversrc, gdpdepay, the chain) of
pipelines/network.sh, over the loopback interface, give the detections of
the single-process chain bit for bit.

Run as SONAR_BUILD_DIR=build SONAR_SOURCE_DIR=. /usr/bin/python3
tests/test_network.py; prints TAP and exits non-zero when a test fails.
"""

import json
import os
import pathlib
import socket
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from taptest import SOURCE_DIR, Skip, run_all, test  # noqa

RECIPE = SOURCE_DIR / "pipelines" / "network.sh"
BANK = "velocity-min=-1.5 velocity-max=1.5"
PINGS = 3


def free_port():
    """A TCP port nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def have(element):
    return subprocess.run(["gst-inspect-1.0", "--exists", element]).returncode == 0


@test
def loopback_matches_one_process():
    """pipelines/network.sh: three pings sent over TCP on the loopback
    interface give exactly the JSON lines of the same chain in one
    process, the set-up arriving through the data protocol"""
    if not have("gdppay"):
        raise Skip("gdppay (gstreamer1.0-plugins-bad) is not installed")
    # Not live: every ping is sent, none lost while the link is busy.
    env = dict(os.environ, SONAR_BANK=BANK, SONAR_LIVE="false")
    port = free_port()
    processing = subprocess.Popen(
        [str(RECIPE), "processing", str(port)], env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # The sensor side connects once the processing side listens (a
        # probe connection would be taken for the sensor's).
        deadline = time.monotonic() + 60
        while True:
            sensor = subprocess.run(
                [str(RECIPE), "sensor", "127.0.0.1", str(port), str(PINGS)],
                env=env, capture_output=True, text=True, timeout=120)
            if sensor.returncode == 0 or "refused" not in sensor.stderr:
                break
            assert processing.poll() is None, processing.communicate()
            assert time.monotonic() < deadline, "nothing listened"
            time.sleep(0.2)
        assert sensor.returncode == 0, sensor.stderr
        remote, errors = processing.communicate(timeout=120)
    finally:
        if processing.poll() is None:
            processing.kill()
    assert processing.returncode == 0, errors
    local = subprocess.run(
        ["gst-launch-1.0", "-q", "sonarsrc", f"num-buffers={PINGS}", "!",
         "dopplerbank", *BANK.split(), "!", "mimobeamform", "!",
         "wardcluster", "!", "velocityest", "!", "fdsink"],
        capture_output=True, text=True, timeout=120, check=True,
        env=dict(os.environ)).stdout
    remote_lines = remote.splitlines()
    assert len(remote_lines) == PINGS, remote
    assert remote_lines == local.splitlines(), (remote, local)
    # Real detections crossed: the default scene's three objects per ping.
    for line in remote_lines:
        valid = [d for d in json.loads(line)["detections"] if d["valid"]]
        assert len(valid) == 3, line


if __name__ == "__main__":
    sys.exit(run_all())
