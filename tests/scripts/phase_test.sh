#!/usr/bin/env bash
# scripts/common.sh's phase timing (scripts/test prints it): a phase that sleeps takes wall time and
# no CPU, one that computes takes CPU, a failing one is marked failed with its status and its status
# is returned, and print_phases lists all three in order; a phase that exits the script is named.
set -uo pipefail
source "$(dirname "$0")/../../scripts/common.sh"

fail() { printf 'FAIL: %s\n%s\n' "$1" "$summary" >&2; exit 1; }

phase "sleeping" sleep 1.2
phase "computing" bash -c 'for ((i = 0; i < 1500000; ++i)); do :; done'
phase "failing" bash -c 'exit 3'
status=$?
summary=$(print_phases)

[ "$status" -eq 3 ] || fail "a failing phase returned $status, not its command's 3"
mapfile -t lines <<<"$summary"
[ ${#lines[@]} -eq 4 ] || fail "expected a heading and 3 phases"
[[ ${lines[0]} =~ ^"==> time per phase (total "[0-9]+" s wall)"$ ]] || fail "heading: ${lines[0]}"
re='^    ([a-z]+) +([0-9]+) s wall +([0-9]+) s CPU(.*)$'
[[ ${lines[1]} =~ $re ]] || fail "line: ${lines[1]}"
[ "${BASH_REMATCH[1]}" = sleeping ] && [ "${BASH_REMATCH[2]}" -ge 1 ] && [ "${BASH_REMATCH[3]}" -eq 0 ] &&
  [ -z "${BASH_REMATCH[4]}" ] || fail "the sleeping phase: ${lines[1]}"
[[ ${lines[2]} =~ $re ]] || fail "line: ${lines[2]}"
[ "${BASH_REMATCH[1]}" = computing ] && [ "${BASH_REMATCH[3]}" -ge 1 ] && [ -z "${BASH_REMATCH[4]}" ] ||
  fail "the computing phase took no CPU: ${lines[2]}"
[[ ${lines[3]} =~ $re ]] || fail "line: ${lines[3]}"
[ "${BASH_REMATCH[1]}" = failing ] && [ "${BASH_REMATCH[4]}" = " (failed: exit 3)" ] ||
  fail "the failing phase: ${lines[3]}"
# A phase that exits the script (die) is named as where the run stopped, after the phases done.
summary=$(bash -c 'source "$1"; trap print_phases EXIT; phase "building" true; phase "dying" die "no compiler"' \
  _ "$(dirname "$0")/../../scripts/common.sh" 2>/dev/null)
mapfile -t lines <<<"$summary"
[ ${#lines[@]} -eq 3 ] && [[ ${lines[1]} =~ ^"    building " ]] &&
  [[ ${lines[2]} =~ ^"    dying "\ +"stopped the run"$ ]] || fail "a phase that called die is not named"
echo "phase timing: ok"
