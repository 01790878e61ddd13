#!/usr/bin/env bash
# `cmake --install` into a fresh prefix yields a working layer: the installed implicit manifest
# loads the installed library under SPLITVK_ENABLE=1, the explicit one under VK_INSTANCE_LAYERS,
# and the agent and the sample are there.
#   install_test.sh BUILD_DIR
set -euo pipefail
build=$1
prefix=$(mktemp -d)
xvfb_pid=
cleanup() { [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null; rm -rf "$prefix"; }
trap cleanup EXIT

cmake --install "$build" --prefix "$prefix" >/dev/null
for f in bin/splitvk-agent bin/splitvk-atrium share/vulkan/implicit_layer.d/VkLayer_splitvk.json \
         share/vulkan/explicit_layer.d/VkLayer_splitvk.json \
         share/openxr/1/api_layers/implicit.d/XrApiLayer_splitvk.json \
         share/openxr/1/api_layers/explicit.d/XrApiLayer_splitvk.json; do
  [ -e "$prefix/$f" ] || { echo "FAIL: $f not installed"; exit 1; }
done
lib=$(find "$prefix" -name libVkLayer_splitvk.so -print -quit)
[ -n "$lib" ] || { echo "FAIL: libVkLayer_splitvk.so not installed"; exit 1; }

# In the ASan+UBSan build (scripts/test's build-asan/) the installed layer is instrumented and
# vkcube is not: the ASan runtime must come first in vkcube's library list (LD_PRELOAD), or the
# layer aborts at dlopen. LeakSanitizer stays off there: it would report lavapipe's and the
# loader's allocations, not splitvk's (whose leaks the unit tests check).
sanitizer_env=()
# awk reads all of ldd's output: an early exit would SIGPIPE ldd, and under pipefail that would end
# this script silently, on some runs only.
asan=$(ldd "$lib" | awk '/libasan\.so/ && !found {print $3; found = 1}')
[ -n "$asan" ] && sanitizer_env=(LD_PRELOAD="$asan" ASAN_OPTIONS=detect_leaks=0)

fifo=$(mktemp -u) && mkfifo "$fifo"
Xvfb -displayfd 3 -screen 0 640x480x24 -nolisten tcp 3>"$fifo" >/dev/null 2>&1 &
xvfb_pid=$!
read -r -t 20 display <"$fifo"; rm -f "$fifo"

# Only the installed manifests and the lavapipe driver are visible to the loader.
run() {
  env -i PATH="$PATH" HOME="$prefix" DISPLAY=":$display" XDG_DATA_DIRS="$prefix/share" \
    XDG_CONFIG_DIRS=/nonexistent XDG_DATA_HOME=/nonexistent XDG_CONFIG_HOME=/nonexistent \
    VK_DRIVER_FILES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json SPLITVK_LOG_LEVEL=info "${sanitizer_env[@]}" "$@" \
    vkcube --c 3 --width 64 --height 64 2>&1
}
expect_active() {
  grep -q "\[splitvk\] info: VK_LAYER_SPLITVK_split_render active in 'vkcube'" <<<"$2" ||
    { echo "FAIL: $1: layer not active"; echo "$2"; exit 1; }
  echo "ok: $1"
}
expect_active "implicit manifest with SPLITVK_ENABLE=1" "$(run SPLITVK_ENABLE=1)"
expect_active "explicit manifest with VK_INSTANCE_LAYERS" \
  "$(run VK_INSTANCE_LAYERS=VK_LAYER_SPLITVK_split_render)"
out=$(run SPLITVK_ENABLE=1 SPLITVK_DISABLE=1)
if grep -q "\[splitvk\]" <<<"$out"; then echo "FAIL: SPLITVK_DISABLE=1 did not keep the layer out"; exit 1; fi
echo "ok: SPLITVK_DISABLE=1"
"$prefix/bin/splitvk-agent" --help >/dev/null
echo "ok: installed splitvk-agent runs"
