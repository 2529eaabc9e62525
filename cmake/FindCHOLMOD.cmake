# FindCHOLMOD
# -----------
# Finds SuiteSparse's CHOLMOD (Debian's libsuitesparse-dev 5.12 ships no CMake package config).
#
# Imported target:   CHOLMOD::CHOLMOD
# Result variables:  CHOLMOD_FOUND, CHOLMOD_INCLUDE_DIR, CHOLMOD_LIBRARIES, CHOLMOD_VERSION
#
# CHOLMOD depends on SuiteSparse_config, AMD, CAMD, COLAMD and CCOLAMD; they are linked too so that
# static or as-needed link orders work.

find_path(CHOLMOD_INCLUDE_DIR NAMES cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY NAMES cholmod)
foreach(_dep suitesparseconfig amd camd colamd ccolamd)
  string(TOUPPER ${_dep} _DEP)
  find_library(CHOLMOD_${_DEP}_LIBRARY NAMES ${_dep})
  mark_as_advanced(CHOLMOD_${_DEP}_LIBRARY)
endforeach()

if(CHOLMOD_INCLUDE_DIR AND EXISTS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h")
  file(STRINGS "${CHOLMOD_INCLUDE_DIR}/cholmod_core.h" _ver REGEX "#define CHOLMOD_(MAIN|SUB)_VERSION +[0-9]+")
  string(REGEX REPLACE ".*CHOLMOD_MAIN_VERSION +([0-9]+).*" "\\1" _major "${_ver}")
  string(REGEX REPLACE ".*CHOLMOD_SUB_VERSION +([0-9]+).*" "\\1" _minor "${_ver}")
  set(CHOLMOD_VERSION "${_major}.${_minor}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD
  REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR CHOLMOD_SUITESPARSECONFIG_LIBRARY
                CHOLMOD_AMD_LIBRARY CHOLMOD_COLAMD_LIBRARY
  VERSION_VAR CHOLMOD_VERSION)

if(CHOLMOD_FOUND)
  set(CHOLMOD_LIBRARIES ${CHOLMOD_LIBRARY} ${CHOLMOD_AMD_LIBRARY} ${CHOLMOD_CAMD_LIBRARY}
                        ${CHOLMOD_COLAMD_LIBRARY} ${CHOLMOD_CCOLAMD_LIBRARY}
                        ${CHOLMOD_SUITESPARSECONFIG_LIBRARY})
  if(NOT TARGET CHOLMOD::CHOLMOD)
    add_library(CHOLMOD::CHOLMOD INTERFACE IMPORTED)
    set_target_properties(CHOLMOD::CHOLMOD PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${CHOLMOD_LIBRARIES}")
  endif()
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY)
