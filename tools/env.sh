# Source this file to use the uninstalled plugin from the build tree:
#   . tools/env.sh && gst-inspect-1.0 sonarsrc
# SONAR_BUILD_DIR picks another build than ./build (the tests set it).
_sonar_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
_sonar_build="${SONAR_BUILD_DIR:-$_sonar_root/build}"
export GST_PLUGIN_PATH_1_0="$_sonar_build/elements${GST_PLUGIN_PATH_1_0:+:$GST_PLUGIN_PATH_1_0}"
export GST_REGISTRY_1_0="$_sonar_build/registry.bin"
unset _sonar_root _sonar_build
