# Warnings are on for everything splitvk compiles; generated code is held to the same bar.
function(splitvk_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wcast-align -Wunused -Woverloaded-virtual -Wformat=2
                                           -Wimplicit-fallthrough)
  if(SPLITVK_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
