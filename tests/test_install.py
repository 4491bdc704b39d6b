#!/usr/bin/python3
"""Installing: meson's install plan honours the prefix; the build installed
into a scratch folder (meson install --destdir) holds the plugin, the
contracts library, its headers and pkg-config file; GStreamer runs the chain
from the installed plugin; the C example builds through pkg-config against
the installed tree and reads the detections meta; the Python example prints
each ping's detections; bus messages are readable from Python.

SONAR_INSTALL_FULL=1: a build of its own configured with --prefix under
/tmp, then ninja install, instead of the staged copy of this build (a
minute more).

Run as SONAR_BUILD_DIR=build SONAR_SOURCE_DIR=. /usr/bin/python3
tests/test_install.py; prints TAP and exits non-zero when a test fails.
"""

import functools
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from taptest import (BUILD_DIR, SANITIZED, SOURCE_DIR, run_all,  # noqa
                     scratch, test)

TMP = scratch("sonar-test-install-")
PYTHON = "/usr/bin/python3"
PC_NAME = "gstsonarcontracts-1.0"
# sonarsrc's default scene on a small bank, three pings.
CHAIN = ("sonarsrc num-buffers=3 ! dopplerbank velocity-min=-1.5 "
         "velocity-max=1.5 ! mimobeamform ! wardcluster ! velocityest")


def run(args, env=None, timeout=300, cwd=None):
    """Run a command; fail with its output when it fails."""
    result = subprocess.run([str(a) for a in args], capture_output=True,
                            text=True, timeout=timeout, env=env, cwd=cwd)
    if result.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, args))} exited "
                             f"{result.returncode}:\n{result.stdout}\n"
                             f"{result.stderr}")
    return result


def build_options(build_dir):
    """The build's options by name (meson introspect)."""
    out = run(["meson", "introspect", "--buildoptions", build_dir]).stdout
    return {o["name"]: o["value"] for o in json.loads(out)}


@functools.cache
def installed():
    """The installed tree: (root of the prefix, libdir under it)."""
    if os.environ.get("SONAR_INSTALL_FULL") == "1":
        prefix = TMP / "full-prefix"
        build = TMP / "full-build"
        run(["meson", "setup", build, SOURCE_DIR, f"--prefix={prefix}",
             "-Dtests=disabled"])
        run(["ninja", "-C", build])
        run(["meson", "install", "-C", build, "--quiet"])
        return prefix, build_options(build)["libdir"]
    stage = TMP / "stage"
    run(["meson", "install", "-C", BUILD_DIR, "--no-rebuild", "--quiet",
         "--destdir", stage])
    options = build_options(BUILD_DIR)
    root = stage / pathlib.Path(options["prefix"]).relative_to("/")
    return root, options["libdir"]


def plugin_dir():
    root, libdir = installed()
    return root / libdir / "gstreamer-1.0"


def installed_env():
    """GStreamer finding the plugin where it was installed, and only
    there; a registry of its own."""
    root, libdir = installed()
    env = dict(os.environ)
    env["GST_PLUGIN_PATH_1_0"] = str(plugin_dir())
    env["GST_REGISTRY_1_0"] = str(TMP / "registry.bin")
    env["LD_LIBRARY_PATH"] = str(root / libdir)
    return env


@functools.cache
def pkg_config_path():
    """Where pkg-config finds the installed .pc file. It is relocatable
    (prefix=${pcfiledir}/...) in a build configured by this meson.build;
    a build directory configured before that has the absolute prefix, which
    a copy points at the staged tree instead."""
    root, libdir = installed()
    folder = root / libdir / "pkgconfig"
    text = (folder / f"{PC_NAME}.pc").read_text()
    prefix = re.search(r"^prefix=(.*)$", text, re.M).group(1)
    if prefix.startswith("${pcfiledir}"):
        return folder
    copy = TMP / "pkgconfig"
    copy.mkdir(exist_ok=True)
    (copy / f"{PC_NAME}.pc").write_text(
        re.sub(r"^prefix=.*$", f"prefix={root}", text, flags=re.M))
    return copy


@test
def prefix_honoured():
    """meson setup --prefix puts everything under the prefix: the plugin
    in <prefix>/<libdir>/gstreamer-1.0, the library and its pkg-config file
    in <libdir>, the headers in <prefix>/include/gst-sonar-1.0"""
    prefix = pathlib.Path("/opt/sonar-prefix-test")
    build = TMP / "configured"
    run(["meson", "setup", build, SOURCE_DIR, f"--prefix={prefix}",
         "-Dtests=disabled"])
    libdir = prefix / build_options(build)["libdir"]
    plan = json.loads(run(["meson", "introspect", "--installed",
                           build]).stdout)
    destinations = [pathlib.Path(d) for d in plan.values()]
    for d in destinations:
        assert prefix in d.parents, f"{d} is outside the prefix {prefix}"
    assert libdir / "gstreamer-1.0" / "libgstsonar.so" in destinations
    assert libdir / "libgstsonarcontracts-1.0.so" in destinations
    assert libdir / "pkgconfig" / f"{PC_NAME}.pc" in destinations
    headers = {d.name for d in destinations
               if d.parent == prefix / "include" / "gst-sonar-1.0"}
    assert "sonar-contracts.h" in headers, headers
    # Relocatable: it holds wherever the tree is installed.
    pc = (build / "meson-private" / f"{PC_NAME}.pc").read_text()
    assert re.search(r"^prefix=\$\{pcfiledir\}", pc, re.M), pc


@test
def installed_tree():
    """The installed tree holds the plugin, linked to the installed
    library (RUNPATH $ORIGIN/..), the library, every header the contracts
    include, and the pkg-config file"""
    root, libdir = installed()
    plugin = plugin_dir() / "libgstsonar.so"
    assert plugin.is_file(), plugin
    assert (root / libdir / "libgstsonarcontracts-1.0.so.0").exists()
    dynamic = run(["readelf", "-d", plugin]).stdout
    assert "[$ORIGIN/..]" in dynamic, dynamic
    assert str(BUILD_DIR) not in dynamic, dynamic
    ldd = run(["ldd", plugin], env=installed_env()).stdout
    assert f"{root / libdir}/libgstsonarcontracts-1.0.so.0" in ldd, ldd
    include = root / "include" / "gst-sonar-1.0"
    for header in re.findall(r'#include "([^"]+)"',
                             (include / "sonar-contracts.h").read_text()):
        assert (include / header).is_file(), header


@test
def installed_plugin_runs():
    """GStreamer loads the installed plugin and runs the chain with it"""
    env = installed_env()
    inspect = run(["gst-inspect-1.0", "sonar"], env=env).stdout
    assert str(plugin_dir() / "libgstsonar.so") in inspect, inspect
    for element in ("sonarsrc", "velocityest", "sonarviz"):
        assert element in inspect, element
    out = run(["gst-launch-1.0", "-q"] + CHAIN.split() + ["!", "fdsink"],
              env=env).stdout
    pings = [json.loads(line) for line in out.splitlines()]
    assert [p["ping"] for p in pings] == [0, 1, 2], out
    assert all(len(p["detections"]) == 3 for p in pings), out


def parse_example(out):
    """read-detections' lines: {(ping, kind): [dict of numbers]}"""
    found = {}
    pattern = re.compile(
        r"ping (\d+) (detection|truth): range (\S+) m, azimuth (\S+) deg, "
        r"elevation (\S+) deg, x (\S+) y (\S+) z (\S+) m, radial velocity "
        r"(\S+) m/s")
    for line in out.splitlines():
        m = pattern.match(line)
        assert m, f"unexpected line: {line}"
        values = dict(zip(("range", "azimuth", "elevation", "x", "y", "z",
                           "v"), map(float, m.groups()[2:])))
        found.setdefault((int(m.group(1)), m.group(2)), []).append(values)
    return found


@functools.cache
def c_example_output():
    """Builds examples/read-detections.c against the installed tree
    through pkg-config and runs it."""
    env = installed_env()
    env["PKG_CONFIG_PATH"] = str(pkg_config_path())
    flags = run(["pkg-config", "--cflags", "--libs", PC_NAME,
                 "gstreamer-app-1.0"], env=env).stdout.split()
    # Nothing from the source or build tree: only the installed headers.
    assert not any(str(SOURCE_DIR) in f or str(BUILD_DIR) in f
                   for f in flags), flags
    program = TMP / "read-detections"
    # A sanitized library (meson test --setup asan) needs its runtime.
    sanitize = (["-fsanitize=address,undefined"]
                if SANITIZED else [])
    run(["cc", "-std=c11", "-Wall", "-Werror",
         SOURCE_DIR / "examples" / "read-detections.c", "-o", program]
        + sanitize + flags, env=env)
    ldd = run(["ldd", program], env=env).stdout
    root, libdir = installed()
    assert f"{root / libdir}/libgstsonarcontracts-1.0.so.0" in ldd, ldd
    return run([program], env=env).stdout


@test
def c_example_reads_detections():
    """An application built through pkg-config reads the detections meta:
    every true object of every ping found within 5 cm and 0.05 m/s, nothing
    else"""
    found = parse_example(c_example_output())
    for ping in range(3):
        truths = found[(ping, "truth")]
        detections = found[(ping, "detection")]
        assert len(truths) == 3 and len(detections) == 3, found
        for t in truths:
            near = [d for d in detections
                    if ((d["x"] - t["x"]) ** 2 + (d["y"] - t["y"]) ** 2
                        + (d["z"] - t["z"]) ** 2) ** 0.5 < 0.05]
            assert len(near) == 1, (t, detections)
            assert abs(near[0]["v"] - t["v"]) < 0.05, (t, near)


@test
def python_example_prints_detections():
    """The Python example (under 30 lines) prints each ping's detections,
    the same as the C application reads from the meta"""
    script = SOURCE_DIR / "examples" / "print-detections.py"
    assert len(script.read_text().splitlines()) < 30
    out = run([PYTHON, script, CHAIN], env=installed_env()).stdout
    lines = out.splitlines()
    c_found = parse_example(c_example_output())
    ping = None
    seen = {}
    for line in lines:
        header = re.match(r"ping (\d+): (\d+) detections$", line)
        if header:
            ping = int(header.group(1))
            seen[ping] = int(header.group(2))
            continue
        m = re.match(r"  (\S+) m  azimuth (\S+)  elevation (\S+) deg  "
                     r"(\S+) m/s$", line)
        assert m and ping is not None, f"unexpected line: {line}"
        r, az, el, v = map(float, m.groups())
        assert any(abs(d["range"] - r) < 0.0006 and abs(d["v"] - v) < 0.0006
                   and abs(d["azimuth"] - az) < 0.06
                   for d in c_found[(ping, "detection")]), line
    assert seen == {0: 3, 1: 3, 2: 3}, out


@test
def bus_messages_in_python():
    """Bus messages are readable from Python: the sonar-detections
    message's list of detections (a GstValueArray, read through
    python3-gst-1.0) holds what the JSON says"""
    probe = """
import json, sys
import gi
gi.require_version("Gst", "1.0")
from gi.repository import Gst
Gst.init(None)
pipeline = Gst.parse_launch(sys.argv[1] + " ! appsink name=sink sync=false")
bus = pipeline.get_bus()
pipeline.set_state(Gst.State.PLAYING)
sink = pipeline.get_by_name("sink")
json_lines, messages = [], []
while (sample := sink.emit("pull-sample")) is not None:
    b = sample.get_buffer()
    json_lines.append(json.loads(b.extract_dup(0, b.get_size())))
while (m := bus.pop_filtered(Gst.MessageType.ELEMENT)) is not None:
    s = m.get_structure()
    if s.get_name() == "sonar-detections":
        messages.append({"ping": s.get_value("ping"), "detections": [
            {"range": d.get_value("range"),
             "radial_velocity": d.get_value("radial_velocity")}
            for d in s.get_value("detections")]})
pipeline.set_state(Gst.State.NULL)
print(json.dumps({"json": json_lines, "messages": messages}))
"""
    result = subprocess.run([PYTHON, "-c", probe, CHAIN], capture_output=True,
                            text=True, timeout=300, env=installed_env())
    if "unknown type GstValueArray" in result.stderr:
        raise AssertionError("GstValueArray unreadable: python3-gst-1.0 "
                             "(tools/setup installs it) is missing")
    assert result.returncode == 0, result.stderr
    got = json.loads(result.stdout)
    assert len(got["messages"]) == 3, got
    for line, message in zip(got["json"], got["messages"]):
        assert line["ping"] == message["ping"]
        assert len(line["detections"]) == len(message["detections"]) == 3
        for a, b in zip(line["detections"], message["detections"]):
            assert abs(a["range"] - b["range"]) < 1e-4
            assert abs(a["radial_velocity"] - b["radial_velocity"]) < 1e-4


if __name__ == "__main__":
    if not shutil.which("cc") or not shutil.which("pkg-config"):
        print("1..0 # SKIP no C compiler or pkg-config")
        sys.exit(0)
    sys.exit(run_all())
