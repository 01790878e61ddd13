# Shared by scripts/test, scripts/demo and scripts/bench: Debian packages, configure, build.
# Sourced, not executed.

SPLITVK_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# Everything splitvk builds, tests, demos and benchmarks with; all Debian 12 packages (docs/architecture.md §1).
# scripts/bench installs the same set (scripts/bench_lib/common.py): python3-matplotlib draws the
# figures of `scripts/bench paper`.
SPLITVK_PACKAGES=(
  cmake make g++ pkg-config python3 python3-matplotlib
  libvulkan-dev vulkan-validationlayers mesa-vulkan-drivers vulkan-tools
  glslang-tools spirv-tools spirv-headers mangohud gfxreconstruct
  libx264-dev libavcodec-dev libavutil-dev libasio-dev libglm-dev libzstd-dev libssl-dev libgtest-dev
  libxcb1-dev libx11-dev xvfb xauth x11-utils ffmpeg
  systemd ccache
  # Agents found over DNS-SD (splitvk-agent --advertise, SPLITVK_SERVER=dnssd), and a pool behind
  # one address; the Pool tests run avahi-daemon, avahi-browse and haproxy in a network namespace.
  libavahi-client-dev avahi-daemon avahi-utils haproxy
  # OpenXR: the API layer's headers, hello_xr and the core validation layer (the tests' first
  # unmodified VR application); scripts/xr-runtime installs what Monado's build needs.
  libopenxr-dev libopenxr-loader1 libopenxr-utils openxr-layer-corevalidation
)

log() { printf '==> %s\n' "$*"; }
die() { printf 'error: %s\n' "$*" >&2; exit 1; }

# Phase timing: `phase NAME command...` runs the command and records its wall time and the CPU time
# (user+sys) of the processes it waited for; print_phases lists them. On a shared machine the wall
# time is inflated by others' load, the CPU time much less: compare runs by the latter.
SPLITVK_PHASES=()
children_cpu_s() { # user+sys of the processes this shell has waited for, from /proc (cutime, cstime)
  local stat
  read -r stat </proc/$$/stat
  set -- ${stat##*) }
  echo $(((${14} + ${15}) / $(getconf CLK_TCK)))
}
phase() {
  local name=$1; shift
  local wall_start=$SECONDS cpu_start rc=0
  cpu_start=$(children_cpu_s)
  SPLITVK_PHASE_RUNNING=$name
  "$@" || rc=$?
  SPLITVK_PHASE_RUNNING=
  SPLITVK_PHASES+=("$(printf '%-24s %5d s wall %6d s CPU%s' "$name" $((SECONDS - wall_start)) \
    $(($(children_cpu_s) - cpu_start)) "$([ $rc -eq 0 ] || echo " (failed: exit $rc)")")")
  return $rc
}
print_phases() {
  [ ${#SPLITVK_PHASES[@]} -eq 0 ] && [ -z "${SPLITVK_PHASE_RUNNING:-}" ] && return 0
  log "time per phase (total ${SECONDS} s wall)"
  [ ${#SPLITVK_PHASES[@]} -eq 0 ] || printf '    %s\n' "${SPLITVK_PHASES[@]}"
  # A phase that called die (exit) never returned to phase().
  [ -z "${SPLITVK_PHASE_RUNNING:-}" ] || printf '    %-24s stopped the run\n' "$SPLITVK_PHASE_RUNNING"
}

# Installs whatever of SPLITVK_PACKAGES is missing, or explains how to when not root.
ensure_packages() {
  local missing=() pkg
  for pkg in "${SPLITVK_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
      log "installing ${missing[*]} (sudo)"
      sudo apt-get update -qq && sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" ||
        die "apt-get could not install: ${missing[*]}"
      return 0
    fi
    die "missing Debian packages: ${missing[*]}; run this script as root, or first: sudo apt-get install ${missing[*]}"
  fi
  log "installing ${missing[*]}"
  local apt_log
  apt_log=$(mktemp)
  { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${missing[@]}"; } >"$apt_log" 2>&1 || { cat "$apt_log"; rm -f "$apt_log"; die "apt-get could not install: ${missing[*]}"; }
  rm -f "$apt_log"
}

# Compiler cache: builds of another clone on this machine (CI's fresh clone, a second work tree)
# reuse what an earlier build compiled. Paths are hashed relative to the clone, so the cache is
# shared whatever folder the clone is in; the cache itself lives outside it (ccache's default,
# ~/.cache/ccache).
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$SPLITVK_ROOT}
# The instrumented builds carry debug info, which would make ccache hash the build folder too;
# a fresh clone's debug info then names the first clone's folders, which only a debugger reads.
export CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
compiler_cache_args() {
  command -v ccache >/dev/null || return 0
  printf '%s\n' -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache
}

# configure BUILD_DIR [cmake args...]
configure() {
  local dir=$1; shift
  log "configuring $dir"
  mkdir -p "$dir"
  local cache_args
  mapfile -t cache_args < <(compiler_cache_args)
  cmake -S "$SPLITVK_ROOT" -B "$dir" -DCMAKE_BUILD_TYPE=Release "${cache_args[@]}" "$@" >"$dir/configure.log" 2>&1 ||
    { cat "$dir/configure.log"; die "cmake configure failed"; }
}

# build BUILD_DIR [targets...]: everything when no target is named.
build() {
  local dir=$1; shift
  local targets=()
  for t in "$@"; do targets+=(--target "$t"); done
  log "building $dir${*:+ ($*)}"
  cmake --build "$dir" -j"$(nproc)" "${targets[@]}" || die "build failed"
}

# splitvk-harness (tests/e2e/harness/harness_cli.cpp) starts Xvfb and the agent, holds an app and
# grabs the screen for the scripts with the e2e tests' own code. Its services report key=value lines
# and "ready", and stop what they started on SIGTERM or when the script that started them exits.
# harness_service VAR REPORT COMMAND...: runs COMMAND (a splitvk-harness service, possibly under
# env) in the background with its report in REPORT, waits for "ready" and sets VAR to its pid.
harness_service() {
  local var=$1 report=$2; shift 2
  "$@" >"$report" &
  local pid=$!
  until grep -qx ready "$report"; do
    # The service gives up by itself (Xvfb in 20 s, the agent in 30 s), with one line on stderr.
    kill -0 "$pid" 2>/dev/null || die "$* did not start"
    sleep 0.1
  done
  printf -v "$var" '%s' "$pid"
}

# harness_value REPORT KEY: KEY's value in a splitvk-harness report.
harness_value() {
  sed -n "s/^$2=//p" "$1" | head -1
}

# ensure_display BUILD_DIR: starts a private Xvfb (BUILD_DIR's splitvk-harness) unless a display is
# already there; sets DISPLAY and SPLITVK_XVFB_PID.
ensure_display() {
  [ -n "${DISPLAY:-}" ] && return 0
  local logs
  logs=$(mktemp -d)
  harness_service SPLITVK_XVFB_PID "$logs/report" "$1/bin/splitvk-harness" xvfb --out-dir "$logs"
  DISPLAY=$(harness_value "$logs/report" display)
  export DISPLAY
  trap 'kill "$SPLITVK_XVFB_PID" 2>/dev/null' EXIT
  log "started Xvfb on $DISPLAY"
}

# The environment that puts the build tree's layer into an application (explicit enable).
layer_env() {
  local build=$1
  printf '%s\n' "VK_ADD_LAYER_PATH=$build/manifest/explicit_layer.d" \
    "VK_INSTANCE_LAYERS=VK_LAYER_SPLITVK_split_render"
}
