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

# CLI11 (command-line options of the programs in apps/): header-only, Debian's
# libcli11-dev ships its CMake package. Its headers sit in /usr/include, so our
# warning flags do not apply to them.
if(NOT GAUSS_LIBRARIES_ONLY)
  find_package(CLI11 CONFIG REQUIRED)
  add_library(gauss_cli11 INTERFACE)
  target_link_libraries(gauss_cli11 INTERFACE CLI11::CLI11)
endif()

# Dear ImGui for the desktop viewer's panels. Debian's libimgui.a holds the core (imgui,
# draw, tables, widgets; its font code calls the stb_truetype/stb_rect_pack of libstb).
# Its prebuilt Vulkan backend calls Vulkan prototypes, which volk (VK_NO_PROTOTYPES) does
# not provide, so the Vulkan and GLFW backends are compiled here from the sources Debian
# ships with the same version; our definitions are linked first, so the archive's
# backend objects are never pulled in. The Vulkan backend then loads its functions
# through ImGui_ImplVulkan_LoadFunctions (see apps/gauss-view/imgui_layer.cpp).
# Desktop only: a libraries-only (cross) build has no viewer to draw panels in.
if(GAUSS_BUILD_GPU AND NOT GAUSS_LIBRARIES_ONLY)
  find_package(glfw3 3.3 CONFIG REQUIRED)
  find_path(IMGUI_INCLUDE_DIR imgui.h PATH_SUFFIXES imgui REQUIRED)
  find_library(IMGUI_CORE_LIBRARY NAMES libimgui.a imgui REQUIRED)
  find_library(STB_LIBRARY NAMES stb REQUIRED)
  find_path(IMGUI_BACKEND_SOURCE_DIR imgui_impl_vulkan.cpp
    PATHS /usr/share/doc/libimgui-dev/examples/backends NO_DEFAULT_PATH REQUIRED)
  add_library(gauss_imgui STATIC
    ${IMGUI_BACKEND_SOURCE_DIR}/imgui_impl_vulkan.cpp
    ${IMGUI_BACKEND_SOURCE_DIR}/imgui_impl_glfw.cpp)
  target_include_directories(gauss_imgui SYSTEM PUBLIC ${IMGUI_INCLUDE_DIR} ${IMGUI_INCLUDE_DIR}/backends)
  target_compile_definitions(gauss_imgui PUBLIC IMGUI_IMPL_VULKAN_NO_PROTOTYPES GLFW_INCLUDE_NONE)
  target_link_libraries(gauss_imgui PUBLIC gauss_volk glfw ${IMGUI_CORE_LIBRARY} ${STB_LIBRARY})
endif()
