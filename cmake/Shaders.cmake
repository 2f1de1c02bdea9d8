# Compiles GLSL to SPIR-V at build time and embeds it as a generated C++ header
# (a uint32_t array named gauss_spv_<file>_<stage>). glslangValidator writes a
# depfile, so editing an #included layout header recompiles the shaders that use it.
# --quiet: it would otherwise print each file's name, which reads like a list of errors in
# a newcomer's first build.
find_program(GLSLANG_VALIDATOR glslangValidator REQUIRED)

function(gauss_compile_shaders out_target)
  set(gen_dir ${CMAKE_CURRENT_BINARY_DIR}/generated)
  set(headers "")
  foreach(src IN LISTS ARGN)
    get_filename_component(abs ${src} ABSOLUTE)
    get_filename_component(name ${src} NAME)
    string(REPLACE "." "_" var ${name})
    set(out ${gen_dir}/gauss/shaders/${name}.spv.h)
    add_custom_command(
      OUTPUT ${out}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${gen_dir}/gauss/shaders
      COMMAND ${GLSLANG_VALIDATOR} --quiet --target-env vulkan1.2 -I${CMAKE_CURRENT_SOURCE_DIR}/shared
              --vn gauss_spv_${var} --depfile ${out}.d -o ${out} ${abs}
      DEPENDS ${abs}
      DEPFILE ${out}.d
      COMMENT "glslang ${name} (generated, do not edit)"
      VERBATIM)
    list(APPEND headers ${out})
  endforeach()
  add_custom_target(${out_target}_spv DEPENDS ${headers})
  add_library(${out_target} INTERFACE)
  add_dependencies(${out_target} ${out_target}_spv)
  target_include_directories(${out_target} INTERFACE ${gen_dir} ${CMAKE_CURRENT_SOURCE_DIR}/shared)
endfunction()
