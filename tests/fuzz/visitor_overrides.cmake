# cmake -DHEADER=vk_codec.h -DOUT=fuzz_visitor_overrides.inc -P visitor_overrides.cmake
# One SPLITVK_FUZZ_VISIT(name) per command the generated CommandVisitor declares, so the fuzz
# visitor follows the allow-list without a hand-kept list of commands.
file(STRINGS "${HEADER}" lines REGEX "^    virtual bool vk[A-Za-z0-9]+\\(const Decoded_")
set(text "// Generated from ${HEADER} by tests/fuzz/visitor_overrides.cmake. Do not edit.\n")
foreach(line IN LISTS lines)
  string(REGEX REPLACE "^    virtual bool (vk[A-Za-z0-9]+)\\(.*$" "\\1" name "${line}")
  string(APPEND text "SPLITVK_FUZZ_VISIT(${name})\n")
endforeach()
file(WRITE "${OUT}.tmp" "${text}")
file(COPY_FILE "${OUT}.tmp" "${OUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUT}.tmp")
