# Finds Debian's OpenSubdiv CPU library by hand: its own OpenSubdivTargets.cmake names a
# libosdCPU.a the package does not ship, so find_package(OpenSubdiv) fails (see DESIGN.md).
find_path(OPENSUBDIV_INCLUDE_DIR opensubdiv/far/topologyRefiner.h REQUIRED)
find_library(OPENSUBDIV_CPU_LIBRARY NAMES osdCPU REQUIRED)
if(NOT TARGET psub_opensubdiv)
  add_library(psub_opensubdiv INTERFACE)
  target_include_directories(psub_opensubdiv SYSTEM INTERFACE ${OPENSUBDIV_INCLUDE_DIR})
  target_link_libraries(psub_opensubdiv INTERFACE ${OPENSUBDIV_CPU_LIBRARY})
endif()
message(STATUS "OpenSubdiv: ${OPENSUBDIV_CPU_LIBRARY} (headers in ${OPENSUBDIV_INCLUDE_DIR})")
