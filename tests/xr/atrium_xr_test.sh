#!/usr/bin/env bash
# xr.AtriumThroughMonado: splitvk-atrium --xr --frames 10 against a real OpenXR runtime (Monado,
# headless null compositor, through scripts/xr-runtime, which builds it into a cache on first use),
# once with one swapchain per eye, once with --multiview and once with --side-by-side, each under
# Khronos validation with synchronization validation. Passes when all exit 0, print all 10 frames,
# the loader inserted the validation layer and the layer logged no error. Validation covers the
# application only: monado-service runs without it.
#
# usage: atrium_xr_test.sh SOURCE_DIR ATRIUM_BINARY       (exit 77: skipped)
set -u
source_dir=$1
atrium=$2
runtime=$source_dir/scripts/xr-runtime
[ -f "$runtime" ] || { echo "SKIP: $runtime is missing"; exit 77; }
if ! ls /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json >/dev/null 2>&1; then
  echo "SKIP: the Khronos validation layer is not installed (vulkan-validationlayers)"
  exit 77
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat >"$work/vk_layer_settings.txt" <<SETTINGS
khronos_validation.enables = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT
khronos_validation.debug_action = VK_DBG_LAYER_ACTION_LOG_MSG
khronos_validation.log_filename = $work/validation.log
khronos_validation.report_flags = error,warn,perf
SETTINGS

failed=0
for layout in per-eye multiview side-by-side; do
  args=(--xr --frames 10)
  [ "$layout" != per-eye ] && args+=("--$layout")
  rm -f "$work/validation.log"
  : >"$work/validation.log"
  bash "$runtime" run -- env VK_INSTANCE_LAYERS=VK_LAYER_KHRONOS_validation VK_LAYER_SETTINGS_PATH="$work" \
    VK_LOADER_DEBUG=layer "$atrium" "${args[@]}" >"$work/out.log" 2>&1
  rc=$?
  problems=()
  [ "$rc" = 0 ] || problems+=("exit code $rc")
  grep -q '^frame-time: .*, 10 frames$' "$work/out.log" || problems+=("no 'frame-time: ..., 10 frames' line")
  grep -q 'Insert instance layer "VK_LAYER_KHRONOS_validation"' "$work/out.log" ||
    problems+=("the loader did not insert VK_LAYER_KHRONOS_validation")
  errors=$(grep -c 'Validation Error' "$work/validation.log")
  [ "$errors" = 0 ] || problems+=("$errors validation errors")
  warnings=$(grep -c 'Validation Warning\|Validation Performance Warning' "$work/validation.log")
  if [ ${#problems[@]} = 0 ]; then
    echo "PASS $layout: $(grep -E '^(xr|frame-time):' "$work/out.log" | tr '\n' ' ')($warnings validation warnings)"
  else
    failed=1
    echo "FAIL $layout: ${problems[*]}"
    grep -v '^LOG\|^	\|LAYER:\|^$' "$work/out.log" | tail -40
    grep -m 20 'Validation' "$work/validation.log"
  fi
done
exit $failed
