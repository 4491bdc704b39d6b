# Source this file to use the uninstalled plugin from the build tree:
#   . tools/env.sh && gst-inspect-1.0 sonarsrc
_sonar_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export GST_PLUGIN_PATH_1_0="$_sonar_root/build/elements${GST_PLUGIN_PATH_1_0:+:$GST_PLUGIN_PATH_1_0}"
export GST_REGISTRY_1_0="$_sonar_root/build/registry.bin"
unset _sonar_root
