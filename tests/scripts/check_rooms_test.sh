#!/usr/bin/env bash
# scripts/check-rooms: the layer's own rooms pass; a tree whose rooms include each other (directly or
# through a third), a file in no room, an include without its room and a .cpp without its header
# each fail with a line naming what is wrong.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
check=$here/../../scripts/check-rooms
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

fail() { printf 'FAIL: %s\n%s\n' "$1" "${2:-}" >&2; exit 1; }

out=$("$check" 2>&1) || fail "the layer's rooms do not pass" "$out"
[[ $out == *"no cycle"* ]] || fail "no summary line for the layer" "$out"

# tree NAME FILE=CONTENT...: a layer tree under $tmp/NAME.
tree() {
  local dir=$tmp/$1 spec; shift
  for spec in "$@"; do
    mkdir -p "$dir/$(dirname "${spec%%=*}")"
    printf '%b' "${spec#*=}" >"$dir/${spec%%=*}"
  done
  echo "$dir"
}
# expect_failure DIR PATTERN WHAT
expect_failure() {
  local out
  out=$("$check" "$1" 2>&1) && fail "$3 passed" "$out"
  [[ $out == *"$2"* ]] || fail "$3: no line with '$2'" "$out"
}

ok=$(tree ok 'low/a.h=#pragma once\n' 'low/a.cpp=#include "low/a.h"\n' 'high/b.h=#include "low/a.h"\n' \
  'high/b.cpp=#include "high/b.h"\n#include "low/a.h"\n#include "vk_codec.h"\n')
out=$("$check" "$ok" 2>&1) || fail "a tree without a cycle failed" "$out"
[[ $out == *"high -> low"* ]] || fail "the room graph lacks high -> low" "$out"

two=$(tree two 'low/a.h=#pragma once\n' 'low/a.cpp=#include "low/a.h"\n#include "high/b.h"\n' \
  'high/b.h=#include "low/a.h"\n')
expect_failure "$two" 'rooms depend on each other: high -> low -> high' "two rooms including each other"
expect_failure "$two" 'layer/low/a.cpp:2: #include "high/b.h"' "two rooms including each other (the include)"

three=$(tree three 'a/x.h=#include "b/y.h"\n' 'b/y.h=#include "c/z.h"\n' 'c/z.h=#include "a/x.h"\n')
expect_failure "$three" 'rooms depend on each other: a -> b -> c -> a' "a cycle through a third room"

loose=$(tree loose 'low/a.h=#pragma once\n' 'stray.cpp=int x;\n')
expect_failure "$loose" 'layer/stray.cpp: in no room' "a file in no room"

bare=$(tree bare 'low/a.h=#pragma once\n' 'high/b.h=#include "a.h"\n')
expect_failure "$bare" 'include it as "low/a.h"' "an include without its room"

lone=$(tree lone 'low/a.cpp=int x;\n')
expect_failure "$lone" 'layer/low/a.cpp: no a.h beside it' "a .cpp without its header"
echo "check-rooms: all cases as expected"
