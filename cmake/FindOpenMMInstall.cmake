# Finds an installed OpenMM, 7.7 to 8.6, by its layout rather than by any one distribution's paths.
#
# OPENMM_DIR (cache) is the prefix that holds OpenMM's include/ and lib/: <site-packages>/OpenMM.libs for the PyPI
# wheel, $CONDA_PREFIX for conda, /usr for Debian's package.  Left empty, the system's default paths are searched.
#
# Sets:
#   OPENMM_INCLUDE_DIR      the folder holding OpenMM.h
#   OPENMM_HEADER_ROOT      the folder holding openmm/Context.h (platform headers are under openmm/<platform>)
#   OPENMM_LIBRARY, OPENMM_LIBRARY_DIR, OPENMM_DRUDE_LIBRARY, OPENMM_DRUDE_LIBRARY_DIR
#   OPENMM_PLUGIN_DIR       the folder holding OpenMM's platform plugins (libOpenMMCPU.so)
#   OPENMM_CPU_LIBRARY, OPENMM_OPENCL_LIBRARY, OPENMM_CUDA_LIBRARY (the last two may be NOTFOUND)
#   OPENMM_VERSION, OPENMM_VERSION_MAJOR, OPENMM_VERSION_MINOR   read from the library itself
#   OPENMM_HAS_LEPTON_HEADERS, OPENMM_HAS_SFMT_HEADERS           whether the install ships them (Debian's does not)
set(OPENMM_DIR "" CACHE PATH
    "OpenMM's install prefix (holding include/ and lib/): <site-packages>/OpenMM.libs, \$CONDA_PREFIX or /usr")

# A pip build (scikit-build-core) compiles against the openmm wheel of its build environment.
if(NOT OPENMM_DIR AND SKBUILD)
    find_package(Python3 REQUIRED COMPONENTS Interpreter)
    execute_process(COMMAND ${Python3_EXECUTABLE} -c
        "import os, openmm.version as v; print(os.path.dirname(v.openmm_library_path), end='')"
        OUTPUT_VARIABLE _wheel_dir RESULT_VARIABLE _wheel_result)
    if(NOT _wheel_result EQUAL 0)
        message(FATAL_ERROR "A pip build needs the openmm package in its build environment (pyproject.toml)")
    endif()
    set(OPENMM_DIR ${_wheel_dir} CACHE PATH "" FORCE)
endif()
if(OPENMM_DIR)
    set(_openmm_search PATHS ${OPENMM_DIR} NO_DEFAULT_PATH)
else()
    set(_openmm_search)
endif()
find_path(OPENMM_INCLUDE_DIR OpenMM.h PATH_SUFFIXES include include/openmm ${_openmm_search} REQUIRED)
find_path(OPENMM_HEADER_ROOT openmm/Context.h PATH_SUFFIXES include ${_openmm_search} REQUIRED)
find_library(OPENMM_LIBRARY OpenMM PATH_SUFFIXES lib lib/${CMAKE_LIBRARY_ARCHITECTURE} lib64 ${_openmm_search} REQUIRED)
get_filename_component(OPENMM_LIBRARY_DIR ${OPENMM_LIBRARY} DIRECTORY)
# The wheel and conda keep the plugin libraries (Drude) beside libOpenMM and the platforms in lib/plugins; Debian puts
# both one folder down, in lib/<triplet>/openmm.
find_library(OPENMM_DRUDE_LIBRARY OpenMMDrude PATHS ${OPENMM_LIBRARY_DIR} ${OPENMM_LIBRARY_DIR}/openmm NO_DEFAULT_PATH
    REQUIRED)
get_filename_component(OPENMM_DRUDE_LIBRARY_DIR ${OPENMM_DRUDE_LIBRARY} DIRECTORY)
find_path(OPENMM_PLUGIN_DIR libOpenMMCPU.so PATHS ${OPENMM_LIBRARY_DIR}/plugins ${OPENMM_LIBRARY_DIR}/openmm/plugins
    NO_DEFAULT_PATH REQUIRED DOC "OpenMM's plugin directory")
find_library(OPENMM_CPU_LIBRARY OpenMMCPU PATHS ${OPENMM_PLUGIN_DIR} NO_DEFAULT_PATH REQUIRED)
find_library(OPENMM_OPENCL_LIBRARY OpenMMOpenCL PATHS ${OPENMM_PLUGIN_DIR} NO_DEFAULT_PATH)
find_library(OPENMM_CUDA_LIBRARY OpenMMCUDA PATHS ${OPENMM_PLUGIN_DIR} NO_DEFAULT_PATH)

if(EXISTS ${OPENMM_HEADER_ROOT}/lepton/CustomFunction.h)
    set(OPENMM_HAS_LEPTON_HEADERS ON)
else()
    set(OPENMM_HAS_LEPTON_HEADERS OFF)
endif()
if(EXISTS ${OPENMM_HEADER_ROOT}/sfmt/SFMT.h)
    set(OPENMM_HAS_SFMT_HEADERS ON)
else()
    set(OPENMM_HAS_SFMT_HEADERS OFF)
endif()

# No OpenMM ships a version macro; ask the library.
if(NOT OPENMM_VERSION OR NOT OPENMM_VERSION_LIBRARY STREQUAL OPENMM_LIBRARY)
    set(_probe ${CMAKE_BINARY_DIR}/CMakeFiles/openmm_version.cpp)
    file(WRITE ${_probe} "#include \"openmm/Platform.h\"\n#include <iostream>\n"
        "int main() { std::cout << OpenMM::Platform::getOpenMMVersion(); return 0; }\n")
    try_run(_run_result _compile_result ${CMAKE_BINARY_DIR}/CMakeFiles/openmm_version ${_probe}
        CMAKE_FLAGS "-DINCLUDE_DIRECTORIES=${OPENMM_HEADER_ROOT};${OPENMM_INCLUDE_DIR}"
        LINK_LIBRARIES ${OPENMM_LIBRARY} "-Wl,-rpath,${OPENMM_LIBRARY_DIR}"
        CXX_STANDARD 17
        COMPILE_OUTPUT_VARIABLE _compile_output RUN_OUTPUT_VARIABLE _version)
    if(NOT _compile_result OR NOT _run_result EQUAL 0)
        message(FATAL_ERROR "Could not read OpenMM's version from ${OPENMM_LIBRARY}:\n${_compile_output}")
    endif()
    string(STRIP "${_version}" _version)
    set(OPENMM_VERSION ${_version} CACHE INTERNAL "")
    set(OPENMM_VERSION_LIBRARY ${OPENMM_LIBRARY} CACHE INTERNAL "")
endif()
string(REGEX MATCH "^([0-9]+)\\.([0-9]+)" _matched "${OPENMM_VERSION}")
set(OPENMM_VERSION_MAJOR ${CMAKE_MATCH_1})
set(OPENMM_VERSION_MINOR ${CMAKE_MATCH_2})
if(OPENMM_VERSION VERSION_LESS 7.7 OR OPENMM_VERSION VERSION_GREATER_EQUAL 8.7)
    message(WARNING "OpenMM ${OPENMM_VERSION}: this project is built and tested against OpenMM 7.7 to 8.6")
endif()
message(STATUS "OpenMM ${OPENMM_VERSION}: ${OPENMM_LIBRARY} (plugins in ${OPENMM_PLUGIN_DIR})")
