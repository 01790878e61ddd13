#!/usr/bin/env bash
# scripts/xr-runtime run against the real monado-service (built on first use, as for the xr tests):
#  - the service killed while the application hangs on: the run returns within a bound, fails, and
#    says in one line how the service died and where its log is (SPLITVK_XR_SERVICE_LOG);
#  - the service killed and the application exiting by itself: its status is returned, the line
#    says so, and without SPLITVK_XR_SERVICE_LOG the log is kept where the line says;
#  - a run where nothing dies: the application's status, its standard input passed through, no
#    line, and neither the service nor the run's folder left behind;
#  - the Vulkan layers the application is run with are not loaded into the service;
#  - the script itself terminated (a test's timeout): the application and the service go with it.
# Every run is bounded by timeout(1), so a script that blocks fails this test instead of hanging it.
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
runtime=$root/scripts/xr-runtime
work=$(mktemp -d)
stderr=

# Only the processes and folders this test's runs recorded, and a pid only while it still names
# what was recorded (the application's sleep, the service), not a process that reused it.
cleanup() {
  local f pid dir comm
  for f in "$work"/*/app.pid "$work"/*/service.pid; do
    [ -s "$f" ] || continue
    pid=$(cat "$f")
    comm=$(cat "/proc/$pid/comm" 2>/dev/null)
    [ "$comm" = sleep ] || [ "$comm" = monado-service ] || continue
    kill -KILL "$pid" 2>/dev/null
  done
  for f in "$work"/*/runtime.dir; do
    [ -s "$f" ] || continue
    dir=$(cat "$f")
    case $dir in /tmp/* | "${TMPDIR:-/tmp}"/*) rm -rf "$dir" ;; esac
  done
  rm -rf "$work"
}
trap cleanup EXIT

fail() {
  printf 'FAIL: %s\n' "$1" >&2
  [ -f "$stderr" ] && sed 's/^/    | /' "$stderr" >&2
  exit 1
}

bash "$runtime" build >/dev/null || fail "scripts/xr-runtime build failed"

# The application of every run: it records its pid, its sibling monado-service's (both are
# children of the script) and the run's XDG_RUNTIME_DIR in its case's folder, then does as told.
cat >"$work/app" <<'APP'
#!/usr/bin/env bash
echo $$ >"$APP_DIR/app.pid"
pgrep -P "$PPID" -x monado-service >"$APP_DIR/service.pid"
echo "$XDG_RUNTIME_DIR" >"$APP_DIR/runtime.dir"
case $1 in
  kill-and-hang) kill -"$2" "$(cat "$APP_DIR/service.pid")"; exec sleep 300 ;;
  kill-and-exit) kill -"$2" "$(cat "$APP_DIR/service.pid")"; sleep 1; exit "$3" ;;
  read-and-exit) read -r line; echo "$line" >"$APP_DIR/read"; exit "$2" ;;
  hang) exec sleep 300 ;;
  layers)
    # The service creates its compositor's Vulkan device for the first session: an OpenXR
    # application runs until its input closes, and the service's libraries are read meanwhile.
    hello_xr -g Vulkan2 < <(sleep 10) >"$APP_DIR/hello_xr.log" 2>&1 &
    maps=/proc/$(cat "$APP_DIR/service.pid")/maps
    for _ in $(seq 1 100); do
      grep -q libVkLayer_MESA_device_select "$maps" && break
      sleep 0.1
    done
    cp "$maps" "$APP_DIR/service.maps"
    wait $!
    ;;
esac
APP
chmod +x "$work/app"

# run_case NAME BOUND [ENV=VALUE...] -- APP-ARGS...: xr-runtime run of the app, its standard input
# from $input; sets rc, elapsed, stderr and dir.
input=/dev/null
run_case() {
  local name=$1 bound=$2 start
  shift 2
  local envs=()
  while [ "$1" != -- ]; do envs+=("$1"); shift; done
  shift
  dir=$work/$name
  mkdir -p "$dir"
  stderr=$dir/stderr
  start=$(date +%s%N)
  env -u SPLITVK_XR_SERVICE_LOG APP_DIR="$dir" "${envs[@]}" timeout -k 5 "$bound" bash "$runtime" run -- "$work/app" "$@" \
    <"$input" >"$dir/stdout" 2>"$stderr"
  rc=$?
  elapsed=$((($(date +%s%N) - start) / 1000000))
  [ "$rc" -ne 124 ] && [ "$rc" -ne 137 ] || fail "$name: xr-runtime run did not return within $bound s"
  [ -s "$dir/app.pid" ] || fail "$name: the application did not run"
}

gone() { ! kill -0 "$(cat "$1")" 2>/dev/null; }

# expect_one_line NAME REGEX: stderr is one line matching REGEX, then only the log's quoted lines.
expect_one_line() {
  local lines
  lines=$(grep -c '^error: ' "$stderr")
  [ "$lines" -eq 1 ] || fail "$1: $lines error lines, not one"
  grep -qE "$2" "$stderr" || fail "$1: the line does not match: $2"
  ! grep -v '^error: \|^    monado-service: ' "$stderr" | grep -q . || fail "$1: more than the line and the log"
}

# The service dies while the application hangs on: the application is stopped after the grace
# period (10 s), the run fails, the service's log is where SPLITVK_XR_SERVICE_LOG says.
run_case hang 60 SPLITVK_XR_SERVICE_LOG="$work/hang.log" -- kill-and-hang SEGV
[ "$rc" -ne 0 ] || fail "hang: the run returned 0 although the service died"
[ "$elapsed" -lt 30000 ] || fail "hang: the run took $elapsed ms to notice"
expect_one_line hang "^error: xr-runtime: monado-service died \(SIGSEGV\) while app ran, which was stopped after 10 s more; its log: $work/hang.log"
[ -s "$work/hang.log" ] || fail "hang: no service log at SPLITVK_XR_SERVICE_LOG"
gone "$dir/app.pid" || fail "hang: the application outlived the run"
echo "service killed, application hanging: exit $rc after $elapsed ms"

# The application notices (XR_ERROR_INSTANCE_LOST) and exits with its own status.
run_case exits 60 -- kill-and-exit ABRT 3
[ "$rc" -eq 3 ] || fail "exits: the run returned $rc, not the application's 3"
[ "$elapsed" -lt 10000 ] || fail "exits: the run took $elapsed ms after the application exited"
log=$(cat "$dir/runtime.dir")/service.log
expect_one_line exits "^error: xr-runtime: monado-service died \(SIGABRT\) while app ran, which then exited \(exit status 3\); its log: $log"
[ -s "$log" ] || fail "exits: the log the line names is not there: $log"
echo "service killed, application exiting: exit $rc after $elapsed ms"

# Nothing dies: the application's status and input, no line, nothing left behind.
echo "through the script" >"$work/input"
input=$work/input
run_case clean 60 -- read-and-exit 5
input=/dev/null
[ "$rc" -eq 5 ] || fail "clean: the run returned $rc, not the application's 5"
[ ! -s "$stderr" ] || fail "clean: the script wrote to stderr"
[ "$(cat "$dir/read" 2>/dev/null)" = "through the script" ] || fail "clean: the application did not get the script's input"
gone "$dir/service.pid" || fail "clean: monado-service outlived the run"
[ ! -e "$(cat "$dir/runtime.dir")" ] || fail "clean: the run's folder is left behind"
echo "clean run: exit $rc after $elapsed ms"

# The service is the runtime, not the application: neither the Vulkan layers the application is run
# with nor an implicit splitvk are loaded into it (its compositor's Vulkan device is up by the time
# its socket is).
validation=/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json
if [ ! -f "$validation" ]; then
  echo "layers: skipped, the Khronos validation layer is not installed (vulkan-validationlayers)"
elif ! command -v hello_xr >/dev/null; then
  echo "layers: skipped, hello_xr is not installed (libopenxr-utils)"
else
  run_case layers 90 VK_INSTANCE_LAYERS=VK_LAYER_KHRONOS_validation SPLITVK_ENABLE=1 -- layers
  [ "$rc" -eq 0 ] || fail "layers: the run returned $rc (hello_xr: $(tail -1 "$dir/hello_xr.log"))"
  # Mesa's implicit device-select layer is loaded with every instance: the device is up.
  grep -q libVkLayer_MESA_device_select "$dir/service.maps" ||
    fail "layers: monado-service created no Vulkan instance for the session"
  ! grep -q libVkLayer_khronos_validation "$dir/service.maps" ||
    fail "layers: the application's VK_INSTANCE_LAYERS were loaded into monado-service"
  echo "layers: the application's Vulkan layers stay out of monado-service"
fi

# The script terminated mid-run: the application and the service go with it.
dir=$work/terminated
mkdir -p "$dir"
stderr=$dir/stderr
env -u SPLITVK_XR_SERVICE_LOG APP_DIR="$dir" bash "$runtime" run -- "$work/app" hang </dev/null >/dev/null 2>"$stderr" &
script=$!
for _ in $(seq 1 100); do [ -s "$dir/runtime.dir" ] && break; sleep 0.1; done
[ -s "$dir/runtime.dir" ] || fail "terminated: the application did not start"
kill -TERM "$script"
for _ in $(seq 1 100); do kill -0 "$script" 2>/dev/null || break; sleep 0.1; done
! kill -0 "$script" 2>/dev/null || fail "terminated: the script did not exit within 10 s of SIGTERM"
wait "$script"
rc=$?
[ "$rc" -eq 143 ] || fail "terminated: the script exited $rc, not 143"
gone "$dir/app.pid" || fail "terminated: the application outlived the script"
gone "$dir/service.pid" || fail "terminated: monado-service outlived the script"
[ ! -e "$(cat "$dir/runtime.dir")" ] || fail "terminated: the run's folder is left behind"
echo "script terminated: application and service stopped"
echo "xr-runtime run: ok"
