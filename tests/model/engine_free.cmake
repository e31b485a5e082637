# model.engine_free: model/ is the bottom of the tree (docs/architecture.md, "Folders"). Its files
# include only each other and the standard and Debian libraries it links (toml++, fmt, Eigen):
# nothing from the folders above it (a header that lives in common/, messages/, a node,
# coordinator/ or postprocess/, or the generated closure table), nor the bus, LCM, MPI, OpenFOAM
# or LIGGGHTS; and hemo_model links none of them. Fails naming each file:line that does.
#   cmake -DSOURCE_DIR=<repository> -P engine_free.cmake
# SPDX-License-Identifier: GPL-3.0-or-later
if(NOT SOURCE_DIR)
  message(FATAL_ERROR "usage: cmake -DSOURCE_DIR=<repository> -P engine_free.cmake")
endif()
set(model "${SOURCE_DIR}/model")

# The header names of the folders above (by file name: the tree's includes use bare names).
set(above)
foreach(dir common messages fluid-node particle-node coordinator postprocess)
  file(GLOB_RECURSE files RELATIVE "${SOURCE_DIR}/${dir}" "${SOURCE_DIR}/${dir}/*.h" "${SOURCE_DIR}/${dir}/*.hpp"
       "${SOURCE_DIR}/${dir}/*.H" "${SOURCE_DIR}/${dir}/*.lcm")
  foreach(f ${files})
    get_filename_component(name "${f}" NAME)
    list(APPEND above "${name}")
  endforeach()
endforeach()
file(GLOB own RELATIVE "${model}" "${model}/*")

# Headers of the runtime and the engines, whichever folder they would come from.
set(forbidden_regex "(^|/)(lcm|mpi|hemo/|lammps|liggghts|fix_|pair_|fv[A-Z]|OpenFOAM|closure_table|closure_headers|spdlog|openssl|hdf5|H5)|\\.H$|\\.hpp$")

file(GLOB sources "${model}/*.h" "${model}/*.cpp")
if(NOT sources)
  message(FATAL_ERROR "no sources in ${model}")
endif()
set(found)
set(count 0)
foreach(src ${sources})
  get_filename_component(file "${src}" NAME)
  file(STRINGS "${src}" lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(NOT line MATCHES "^[ \t]*#[ \t]*include[ \t]*[<\"]([^>\"]+)[>\"]")
      continue()
    endif()
    set(header "${CMAKE_MATCH_1}")
    math(EXPR count "${count} + 1")
    get_filename_component(name "${header}" NAME)
    list(FIND own "${name}" is_own)
    list(FIND above "${name}" is_above)
    if(is_own LESS 0 AND NOT is_above LESS 0)
      list(APPEND found "model/${file}:${n}: includes ${header}, a header of a folder above model/")
    elseif(is_own LESS 0 AND header MATCHES "${forbidden_regex}")
      list(APPEND found "model/${file}:${n}: includes ${header} (the bus, MPI, HDF5 or an engine)")
    endif()
  endforeach()
endforeach()

# What hemo_model links.
file(READ "${model}/CMakeLists.txt" cmake)
string(REGEX MATCHALL "target_link_libraries\\(hemo_model[^)]*\\)" links "${cmake}")
if(NOT links)
  list(APPEND found "model/CMakeLists.txt: no target_link_libraries(hemo_model ...) to check")
endif()
foreach(l ${links})
  if(l MATCHES "(hemocommon|hemoruntime|hemo_messages|hemo_closure_table|hemo_particle|hemo_fluid|LCM|MPI|HDF5|OpenSSL|LIGGGHTS|liggghts|OpenFOAM|spdlog)")
    list(APPEND found "model/CMakeLists.txt: hemo_model links ${CMAKE_MATCH_1}")
  endif()
endforeach()

if(found)
  list(JOIN found "\n" text)
  message(FATAL_ERROR "model/ is not engine-free:\n${text}")
endif()
list(LENGTH sources files)
message(STATUS "model/: ${count} includes in ${files} files, none from above, no engine, bus or MPI")
