# Finds Debian's OpenSubdiv CPU library by hand: its own OpenSubdivTargets.cmake names a
# libosdCPU.a the package does not ship, so find_package(OpenSubdiv) fails (docs/design.md).
# Gives the imported target OpenSubdivCPU::OpenSubdivCPU (headers as system headers); PSub's
# package config uses this same file to find it again for psub::catmark's users.
include(FindPackageHandleStandardArgs)
find_path(OPENSUBDIV_INCLUDE_DIR opensubdiv/far/topologyRefiner.h)
find_library(OPENSUBDIV_CPU_LIBRARY NAMES osdCPU)
find_package_handle_standard_args(OpenSubdivCPU
  REQUIRED_VARS OPENSUBDIV_CPU_LIBRARY OPENSUBDIV_INCLUDE_DIR
  REASON_FAILURE_MESSAGE "OpenSubdiv's CPU library and headers (Debian: libosd-dev)")
if(OpenSubdivCPU_FOUND AND NOT TARGET OpenSubdivCPU::OpenSubdivCPU)
  add_library(OpenSubdivCPU::OpenSubdivCPU UNKNOWN IMPORTED)
  set_target_properties(OpenSubdivCPU::OpenSubdivCPU PROPERTIES
    IMPORTED_LOCATION "${OPENSUBDIV_CPU_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${OPENSUBDIV_INCLUDE_DIR}")
endif()
