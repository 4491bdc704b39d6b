#!/usr/bin/python3
"""sonarviz outside the test programs: the pipelines/video.sh recipe records
the Fig. 9 world as H.264 in MP4 and as PNG frames, labelled (red and green
rings and labels where the objects are); under a virtual X server
(Xvfb), autovideosink shows the frames in a real window.

Run as SONAR_BUILD_DIR=build SONAR_SOURCE_DIR=. /usr/bin/python3
tests/test_viz.py; prints TAP and exits non-zero when a test fails.
"""

import os
import pathlib
import select
import shutil
import subprocess
import sys

import matplotlib.image
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from taptest import SOURCE_DIR, Skip, run_all, scratch, test  # noqa: E402

TMP = scratch("sonar-test-viz-")
RECIPE = SOURCE_DIR / "pipelines" / "video.sh"
# sonarviz's marks (gst/sonar-render.c).
APPROACHING = (240, 40, 40)
RECEDING = (40, 235, 60)
TRUTH = (255, 255, 255)
TRACK = (255, 60, 255)


def run(args, timeout=300):
    """Run a command; fail with its output when it fails."""
    result = subprocess.run([str(a) for a in args], capture_output=True,
                            text=True, timeout=timeout)
    if result.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, args))} exited "
                             f"{result.returncode}:\n{result.stdout}\n"
                             f"{result.stderr}")
    return result


def count(image, colour):
    """Pixels of exactly @colour in an RGB(A) image read by matplotlib."""
    rgb = np.rint(image[..., :3] * 255).astype(int)
    return int(np.all(rgb == colour, axis=-1).sum())


@test
def recipe_png_frames():
    """pipelines/video.sh writes PNG frames of the Fig. 9 world: 1280 x 720,
    with the approaching mover's red ring and label, the others' green, six
    white truth rings"""
    pattern = TMP / "fig9-%03d.png"
    run([RECIPE, 2, pattern])
    frames = sorted(TMP.glob("fig9-*.png"))
    assert [f.name for f in frames] == ["fig9-000.png", "fig9-001.png"]
    for frame in frames:
        image = matplotlib.image.imread(frame)
        assert image.shape[:2] == (720, 1280), image.shape
        # A ring of radius 10 px (2 px thick) is ~125 pixels, a label's
        # text a few hundred: one object in red, five in green.
        red, green = count(image, APPROACHING), count(image, RECEDING)
        assert red > 150, red
        assert green > 5 * 150, green
        assert count(image, TRUTH) > 6 * 100
        # No tracks without sonartrack.
        assert count(image, TRACK) == 0


@test
def recipe_tracks():
    """pipelines/video.sh ... tracks draws sonartrack's tracks: six magenta
    squares with their ids, arrows on the two movers; a bad fourth argument
    is refused"""
    frame = TMP / "tracks.png"
    run([RECIPE, 6, frame, "fig9", "tracks"])
    image = matplotlib.image.imread(frame)
    # A square of half side 14 px (2 px thick) is ~220 pixels, an arrow of
    # ~1 m over 100 px a few hundred.
    assert count(image, TRACK) > 6 * 200 + 2 * 150, count(image, TRACK)
    result = subprocess.run([str(RECIPE), "1", str(frame), "fig9", "trakcs"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert 'the fourth argument is "tracks" or nothing' in result.stderr


@test
def recipe_mp4():
    """pipelines/video.sh records H.264 in MP4 at the ping rate, a frame
    per ping"""
    if subprocess.run(["gst-inspect-1.0", "--exists", "x264enc"]).returncode:
        raise Skip("x264enc is missing (Debian: gstreamer1.0-plugins-ugly, "
                   "which tools/setup installs)")
    video = TMP / "fig9.mp4"
    run([RECIPE, 3, video])
    out = run(["gst-launch-1.0", "-v", "filesrc", f"location={video}", "!",
               "qtdemux", "!", "video/x-h264,width=1280,height=720,"
               "framerate=12/1", "!", "fakesink", "silent=false"]).stdout
    assert out.count("chain   ******* (fakesink0:sink)") == 3, out[-2000:]


@test
def window_under_xvfb():
    """Under a virtual X server autovideosink opens a real window
    (ximagesink or xvimagesink, not the headless fake sink) and the chain
    plays to its end"""
    if not shutil.which("Xvfb"):
        raise Skip("Xvfb is missing (Debian: xvfb, which tools/setup "
                   "installs)")
    # Xvfb writes its display number to -displayfd once it accepts
    # clients (xvfb-run's signal handshake fails where SIGUSR1 is ignored).
    # -noreset: an X server resets when its last client leaves, and
    # refuses connections meanwhile; autovideosink's probe of ximagesink is
    # such a client, and the real sink would connect during the reset.
    ready, writer = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(writer), "-noreset",
                             "-screen", "0", "1280x800x24", "-nolisten",
                             "tcp"],
                            pass_fds=(writer,), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(writer)
    try:
        if not select.select([ready], [], [], 30)[0]:
            raise AssertionError("Xvfb did not start within 30 s")
        env = dict(os.environ, DISPLAY=":" + os.read(ready, 32).decode()
                   .strip())
        result = subprocess.run(
            ["gst-launch-1.0", "-v", "sonarsrc", "num-buffers=2", "!",
             "dopplerbank", "velocity-min=-1.5", "velocity-max=1.5", "!",
             "mimobeamform", "!", "sonarviz", "!", "videoconvert", "!",
             "autovideosink"],
            capture_output=True, text=True, timeout=300, env=env)
    finally:
        os.close(ready)
        xvfb.terminate()
        xvfb.wait(timeout=30)
    assert result.returncode == 0, result.stderr
    assert ("GstXImageSink" in result.stdout
            or "GstXvImageSink" in result.stdout), result.stdout[-2000:]
    assert "fake-video-sink" not in result.stdout


if __name__ == "__main__":
    sys.exit(run_all())
