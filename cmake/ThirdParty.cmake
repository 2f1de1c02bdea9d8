# Third-party pieces Debian ships as source, compiled here without our warning flags.

# volk: Debian ships volk.h + volk.c only (no CMake package).
if(GAUSS_BUILD_GPU)
  find_path(VOLK_INCLUDE_DIR volk.h REQUIRED)
  add_library(gauss_volk STATIC ${VOLK_INCLUDE_DIR}/volk.c)
  target_include_directories(gauss_volk SYSTEM PUBLIC ${VOLK_INCLUDE_DIR})
  target_compile_definitions(gauss_volk PUBLIC VK_NO_PROTOTYPES)
  target_link_libraries(gauss_volk PUBLIC Vulkan::Headers ${CMAKE_DL_LIBS})
  set_target_properties(gauss_volk PROPERTIES POSITION_INDEPENDENT_CODE ON)
endif()

# stb (image read/write): header-only, one implementation TU per library in engine/.
find_path(STB_INCLUDE_DIR stb_image.h PATH_SUFFIXES stb REQUIRED)
