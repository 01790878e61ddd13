#!/usr/bin/env bash
# An arm64 client split by an x86-64 agent: splitvk-atrium and the layer cross-built for aarch64 run
# under qemu-aarch64-static on lavapipe for arm64, against the native x86-64 splitvk-agent on
# loopback, under a private Xvfb (splitvk-harness, as the e2e tests start theirs).
#
#   arm64_client_test.sh HOST_BUILD AARCH64_BUILD OUT_DIR [--size WxH] [--frames N] [--codec C]...
#
# For each codec (default: x264, zstd, raw): the arm64 client's native frame and its split frame,
# each held on screen and grabbed from the X server (x11grab, bgr0). Passes when both foveae equal
# native bit for bit and the periphery does not (compare_foveae.py), when every frame was split and
# none came late, when the client's Khronos validation (arm64, synchronization on) logged nothing and
# the agent's session (--validate) closed with 0 validation errors. Everything stays in OUT_DIR.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/../../scripts/common.sh"

[ $# -ge 3 ] || die "usage: $0 HOST_BUILD AARCH64_BUILD OUT_DIR [--size WxH] [--frames N] [--codec C]..."
host=$1 cross=$2 out=$3
shift 3
size=480x216 frames=4 codecs=()
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --frames) frames=$2; shift 2 ;;
    --codec) codecs+=("$2"); shift 2 ;;
    *) die "unknown option $1" ;;
  esac
done
[ ${#codecs[@]} -gt 0 ] || codecs=(x264 zstd raw)
width=${size%x*} height=${size#*x}

harness=$host/bin/splitvk-harness agent=$host/bin/splitvk-agent atrium=$cross/bin/splitvk-atrium
qemu=(qemu-aarch64-static)
lvp_arm64=/usr/share/vulkan/icd.d/lvp_icd.aarch64.json lvp_native=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
for f in "$harness" "$agent" "$atrium" "$cross/lib/libVkLayer_splitvk.so"; do
  [ -f "$f" ] || die "$f is not built"
done
for f in "$lvp_arm64" "$lvp_native" /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json; do
  [ -f "$f" ] || die "$f is missing (scripts/cross-aarch64 build installs it)"
done

# elf_machine FILE: the ELF header's e_machine (x86-64 62, aarch64 183): the case is only what it
# claims if the client is arm64 code and the agent x86-64 code.
elf_machine() {
  od -An -tu2 -j18 -N2 "$1" | tr -d ' '
}
[ "$(elf_machine "$atrium")" = 183 ] && [ "$(elf_machine "$cross/lib/libVkLayer_splitvk.so")" = 183 ] ||
  die "$atrium or its layer is not aarch64 code"
[ "$(elf_machine "$agent")" = 62 ] || die "$agent is not x86-64 code"

rm -rf "$out"
mkdir -p "$out/xdg/config" "$out/xdg/data"
# A clean environment for every program: no Vulkan or splitvk variables of the caller's, no layers
# from ~/.local, nothing on the caller's display.
clean_env=(env -i "PATH=$PATH" "HOME=$HOME" "XDG_CONFIG_HOME=$out/xdg/config" "XDG_DATA_HOME=$out/xdg/data"
  XDG_DATA_DIRS=/usr/share)

pids=()
cleanup() {
  local pid
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT

# The reports exist before harness_service polls them.
: >"$out/xvfb.report"
: >"$out/agent.report"
harness_service xvfb_pid "$out/xvfb.report" "${clean_env[@]}" "$harness" xvfb --out-dir "$out"
pids+=("$xvfb_pid")
display=$(harness_value "$out/xvfb.report" display)
harness_service agent_pid "$out/agent.report" "${clean_env[@]}" "VK_DRIVER_FILES=$lvp_native" \
  "$harness" agent --out-dir "$out" -- "$agent" --validate
pids+=("$agent_pid")
address=$(harness_value "$out/agent.report" address)
agent_log=$(harness_value "$out/agent.report" log)
log "Xvfb on $display; x86-64 splitvk-agent --validate at $address"

# atrium's own scene is 300k triangles, which lavapipe under qemu takes minutes a frame to draw; a
# floor and a box (tests/data/floor_and_box.obj, the soak test's: 12 triangles, atrium's procedural
# textures on both) take the same layer, wire and codec paths in seconds.
atrium_args=(--width "$width" --height "$height" --eyes 2 --frames "$frames" --hold --model "$here/../data/floor_and_box.obj")

# hold NAME ENV...: the arm64 atrium held at its last frame, grabbed to OUT_DIR/NAME.raw; prints the
# path of its stderr.
hold() {
  local name=$1 start=$SECONDS
  shift
  "${clean_env[@]}" "DISPLAY=$display" "VK_DRIVER_FILES=$lvp_arm64" "$@" \
    "$harness" hold --out-dir "$out" --name "$name" --frame $((frames - 1)) --grab "$out/$name.raw" \
    --size "$size" --pix-fmt bgr0 --timeout 1200 -- "${qemu[@]}" "$atrium" "${atrium_args[@]}" \
    >"$out/$name.report" || die "$name: the arm64 atrium did not hold its frame (logs in $out)"
  log "$name: $frames frames of the arm64 atrium at $size under qemu, grabbed ($((SECONDS - start)) s)" >&2
  harness_value "$out/$name.report" stderr
}

failures=0
fail() {
  printf 'FAIL: %s\n' "$*" >&2
  failures=$((failures + 1))
}

hold native >/dev/null
for codec in "${codecs[@]}"; do
  name=split-$codec
  mkdir -p "$out/$name"
  cat >"$out/$name/vk_layer_settings.txt" <<EOF
khronos_validation.enables = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT
khronos_validation.debug_action = VK_DBG_LAYER_ACTION_LOG_MSG
khronos_validation.log_filename = $out/$name/validation.log
khronos_validation.report_flags = error,warn,perf
EOF
  err=$(hold "$name" "VK_ADD_LAYER_PATH=$cross/manifest/explicit_layer.d" \
    VK_INSTANCE_LAYERS=VK_LAYER_SPLITVK_split_render:VK_LAYER_KHRONOS_validation \
    "VK_LAYER_SETTINGS_PATH=$out/$name" "SPLITVK_SERVER=$address" "SPLITVK_CODEC=$codec" \
    SPLITVK_TILE_WAIT=60000 SPLITVK_LOG_LEVEL=info)
  grep -q "^\[splitvk\] info: VK_LAYER_SPLITVK_split_render active in " "$err" || fail "$name: the layer did not load ($err)"
  ! grep -E "running unsplit|^\[splitvk\] (error|warning):" "$err" || fail "$name: the layer complained ($err)"
  summary=$(grep -E "^\[splitvk\] split: [0-9]+ frames, .* [0-9]+ late$" "$err" | tail -1 || true)
  [ -n "$summary" ] || fail "$name: no split summary in $err"
  [ "${summary##* }" = late ] && [ "$(awk '{print $(NF-1)}' <<<"$summary")" = 0 ] || fail "$name: late frames: $summary"
  printf '    %s\n' "$summary"
  if [ ! -f "$out/$name/validation.log" ]; then
    fail "$name: the arm64 validation layer did not load (no $out/$name/validation.log)"
  elif [ -s "$out/$name/validation.log" ]; then
    fail "$name: client validation reported: $(head -c 2000 "$out/$name/validation.log")"
  fi
  python3 "$here/compare_foveae.py" --size "$size" --eyes 2 "$out/native.raw" "$out/$name.raw" |
    sed 's/^/    /' || fail "$name: the foveae are not native's ($out/$name.raw against $out/native.raw)"
done

# Every session the agent served closed, and under validation none had an error.
sessions=${#codecs[@]}
for _ in $(seq 200); do
  [ "$(grep -c ': closed after ' "$agent_log")" -ge "$sessions" ] && break
  sleep 0.1
done
closed=$(grep ': closed after ' "$agent_log" || true)
[ "$(grep -c . <<<"$closed")" -eq "$sessions" ] || fail "the agent closed $(grep -c . <<<"$closed") sessions, not $sessions ($agent_log)"
! grep -v '; 0 validation errors, 0 validation warnings;' <<<"$closed" || fail "agent-side validation was not clean ($agent_log)"
[ "$failures" -eq 0 ] || die "$failures check(s) failed; everything is in $out"
log "arm64 client, x86-64 agent: ${codecs[*]}: foveae bit-exact against native, validation clean on both sides"
