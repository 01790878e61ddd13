# Warnings are on for everything splitvk compiles; generated code is held to the same bar.
function(splitvk_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wcast-align -Wunused -Woverloaded-virtual -Wformat=2
                                           -Wimplicit-fallthrough)
  if(SPLITVK_SANITIZE AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12's flow analysis misreads ASan's instrumentation and reports maybe-uninitialized inside
    # libstdc++ (std::regex, std::function); the Release build keeps the warning.
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(SPLITVK_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
