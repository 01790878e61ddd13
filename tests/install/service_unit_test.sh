#!/usr/bin/env bash
# `cmake --install` installs splitvk-agent.service: a unit systemd accepts without a warning
# (`systemd-analyze verify`), naming the installed agent, with the sandboxing the issue asks for,
# and an exposure that `systemd-analyze security` rates OK (at most 2.0 of 10).
#   service_unit_test.sh BUILD_DIR
# Exit status 77 (a skip for ctest) when systemd-analyze cannot run here.
set -euo pipefail
build=$1
prefix=$(mktemp -d)
probe=$(mktemp -d)
trap 'rm -rf "$prefix" "$probe"' EXIT

if ! command -v systemd-analyze >/dev/null; then
  echo "SKIP: systemd-analyze is not installed (Debian package systemd)"; exit 77
fi
printf '[Service]\nExecStart=/bin/true\n' >"$probe/probe.service"
if ! out=$(systemd-analyze verify "$probe/probe.service" 2>&1); then
  echo "SKIP: systemd-analyze verify cannot run in this sandbox: $out"; exit 77
fi

cmake --install "$build" --prefix "$prefix" >/dev/null
unit="$prefix/lib/systemd/system/splitvk-agent.service"
[ -f "$unit" ] || { echo "FAIL: $unit not installed"; exit 1; }
grep -qx "ExecStart=$prefix/bin/splitvk-agent --listen 127.0.0.1:7447" "$unit" ||
  { echo "FAIL: ExecStart does not name the installed agent:"; grep ExecStart "$unit"; exit 1; }
for directive in DynamicUser=yes ProtectSystem=strict NoNewPrivileges=yes PrivateTmp=yes \
                 DevicePolicy=closed "DeviceAllow=char-drm rw" "DeviceAllow=char-nvidia-frontend rw" \
                 StateDirectory=splitvk-agent "RestrictAddressFamilies=AF_INET AF_INET6 AF_UNIX"; do
  grep -qx "$directive" "$unit" || { echo "FAIL: $directive missing"; exit 1; }
done
echo "ok: installed, ExecStart=$prefix/bin/splitvk-agent, sandboxing directives present"

# verify exits 0 on unknown or misspelt keys and only warns: any output fails the test.
if ! out=$(systemd-analyze verify "$unit" 2>&1) || [ -n "$out" ]; then
  echo "FAIL: systemd-analyze verify:"; echo "$out"; exit 1
fi
echo "ok: systemd-analyze verify"

if ! out=$(systemd-analyze security --offline=yes --threshold=20 "$unit" 2>&1); then
  echo "FAIL: systemd-analyze security rates the unit above 2.0:"; echo "$out"; exit 1
fi
echo "ok: $(grep -o 'Overall exposure level.*' <<<"$out")"

# The template, one instance per GPU: the same confinement, the instance as --device, advertised.
template="$prefix/lib/systemd/system/splitvk-agent@.service"
[ -f "$template" ] || { echo "FAIL: $template not installed"; exit 1; }
grep -qx 'ExecStart='"$prefix"'/bin/splitvk-agent --listen ${AGENT_LISTEN} --device %i --advertise $AGENT_ARGS' "$template" ||
  { echo "FAIL: the template's ExecStart:"; grep ExecStart "$template"; exit 1; }
diff <(grep -E '^(DynamicUser|Protect|NoNewPrivileges|Private|DevicePolicy|DeviceAllow|Restrict|SystemCall|Capability|Lock|RemoveIPC|UMask)' "$unit") \
     <(grep -E '^(DynamicUser|Protect|NoNewPrivileges|Private|DevicePolicy|DeviceAllow|Restrict|SystemCall|Capability|Lock|RemoveIPC|UMask)' "$template") ||
  { echo "FAIL: the template is confined otherwise than splitvk-agent.service"; exit 1; }
# systemd verifies a template through an instance of it: one by index, one by UUID.
instances=$(mktemp -d)
trap 'rm -rf "$prefix" "$probe" "$instances"' EXIT
for instance in 0 6b39a0f2-1c1d-4e55-8a8e-0123456789ab; do
  cp "$template" "$instances/splitvk-agent@.service"
  if ! out=$(cd "$instances" && systemd-analyze verify "$instances/splitvk-agent@$instance.service" 2>&1) || [ -n "$out" ]; then
    echo "FAIL: systemd-analyze verify splitvk-agent@$instance.service:"; echo "$out"; exit 1
  fi
done
echo "ok: systemd-analyze verify splitvk-agent@0.service and @UUID.service"
if ! out=$(systemd-analyze security --offline=yes --threshold=20 "$instances/splitvk-agent@0.service" 2>&1); then
  echo "FAIL: systemd-analyze security rates the template above 2.0:"; echo "$out"; exit 1
fi
echo "ok: template $(grep -o 'Overall exposure level.*' <<<"$out")"
