"""taptest.py: what the Python test programs share: the source and build
folders, a scratch folder removed at exit, a registry of test cases (each
named by its docstring's first sentence) and a runner that prints TAP.

    from taptest import BUILD_DIR, test, run_all
    @test
    def something():
        \"\"\"what it checks\"\"\"
    if __name__ == "__main__":
        sys.exit(run_all())
"""

import atexit
import os
import pathlib
import shutil
import sys
import tempfile
import traceback

SOURCE_DIR = pathlib.Path(os.environ.get(
    "SONAR_SOURCE_DIR", pathlib.Path(__file__).resolve().parent.parent))
BUILD_DIR = pathlib.Path(os.environ.get("SONAR_BUILD_DIR",
                                        SOURCE_DIR / "build"))
# Under AddressSanitizer and UBSan (meson test --setup asan): their
# allocator is not glibc's, and the code runs about five times slower.
SANITIZED = bool(os.environ.get("SONAR_SANITIZED"))
# tools/test's second compiler's run (build-clang): the statistical
# calibrations, long 3-D runs of a property no compiler changes, are the
# first run's to check.
SECOND_COMPILER = bool(os.environ.get("SONAR_SECOND_COMPILER"))

TESTS = []


class Skip(Exception):
    """The case cannot run here; its message says why."""


def scratch(prefix):
    """A new temporary folder, removed when the program ends."""
    folder = pathlib.Path(tempfile.mkdtemp(prefix=prefix))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def test(function):
    """Register a test case; its docstring's first line is its TAP name."""
    TESTS.append(function)
    return function


def run_all():
    """Run every test, print TAP, return 1 on failure (the exit status)."""
    print(f"1..{len(TESTS)}")
    failed = 0
    for number, function in enumerate(TESTS, 1):
        name = " ".join(function.__doc__.split())
        try:
            function()
        except Skip as reason:
            print(f"ok {number} - {name} # SKIP {reason}")
        except Exception:  # a crash fails the case, not the run
            failed += 1
            print(f"not ok {number} - {name}")
            for line in traceback.format_exc().splitlines():
                print(f"# {line}")
        else:
            print(f"ok {number} - {name}")
        sys.stdout.flush()
    return 1 if failed else 0
