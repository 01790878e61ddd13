# Compile GLSL to SPIR-V with glslang at build time, validate it with spirv-val, and embed the words
# in a generated header so binaries need no shader files at run time.
find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)
find_program(SPIRV_VAL spirv-val REQUIRED)

# splitvk_add_shaders(TARGET <target> HEADER <name.h> NAMESPACE <c++ namespace> [TARGET_ENV vulkan1.0]
#                     SOURCES a.vert b.frag ...)
# TARGET_ENV (default vulkan1.1) is glslang's and spirv-val's --target-env: code the layer runs on
# the application's device must be vulkan1.0 (SPIR-V 1.0), since the application may ask for 1.0.
# Emits ${CMAKE_CURRENT_BINARY_DIR}/shaders/<name.h> with `const uint32_t <ns>::<stem>_<stage>[]` arrays
# and adds that directory to the target's include path.
function(splitvk_add_shaders)
  cmake_parse_arguments(ARG "" "TARGET;HEADER;NAMESPACE;TARGET_ENV" "SOURCES" ${ARGN})
  if(NOT ARG_TARGET_ENV)
    set(ARG_TARGET_ENV vulkan1.1)
  endif()
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/shaders)
  set(spv_files)
  foreach(src ${ARG_SOURCES})
    get_filename_component(abs ${src} ABSOLUTE)
    get_filename_component(name ${src} NAME)
    set(spv ${out_dir}/${name}.spv)
    add_custom_command(
      OUTPUT ${spv}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
      COMMAND ${GLSLANG_VALIDATOR} --quiet -V --target-env ${ARG_TARGET_ENV} -o ${spv} ${abs}
      COMMAND ${SPIRV_VAL} --target-env ${ARG_TARGET_ENV} ${spv}
      DEPENDS ${abs}
      COMMENT "glslang + spirv-val ${name}"
      VERBATIM)
    list(APPEND spv_files ${spv})
  endforeach()
  set(header ${out_dir}/${ARG_HEADER})
  add_custom_command(
    OUTPUT ${header}
    COMMAND ${Python3_EXECUTABLE} ${PROJECT_SOURCE_DIR}/cmake/embed_spirv.py --namespace ${ARG_NAMESPACE}
            --output ${header} ${spv_files}
    DEPENDS ${spv_files} ${PROJECT_SOURCE_DIR}/cmake/embed_spirv.py
    COMMENT "embed SPIR-V into ${ARG_HEADER}"
    VERBATIM)
  add_custom_target(${ARG_TARGET}_spirv DEPENDS ${header})
  add_dependencies(${ARG_TARGET} ${ARG_TARGET}_spirv)
  target_include_directories(${ARG_TARGET} PRIVATE ${out_dir})
  target_sources(${ARG_TARGET} PRIVATE ${header})
endfunction()
