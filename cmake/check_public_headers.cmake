# cmake -DSODA_SOURCE_DIR=<repo> -P cmake/check_public_headers.cmake
# Fails if a public header (<folder>/include/soda/<folder>/*.h, installed by
# `cmake --install`) includes anything in quotes that is not another public
# header: an internal header (<folder>/src/...) would be missing from an
# installed tree. Third-party and standard headers use <...>. The CI step of
# scripts/test.sh also compiles every installed header alone against the
# installed tree (tests/install/).
cmake_minimum_required(VERSION 3.25)
if(NOT SODA_SOURCE_DIR)
  message(FATAL_ERROR "usage: cmake -DSODA_SOURCE_DIR=<repo> -P check_public_headers.cmake")
endif()
file(GLOB headers RELATIVE ${SODA_SOURCE_DIR} ${SODA_SOURCE_DIR}/*/include/soda/*/*.h)
set(public "")
foreach(h IN LISTS headers)
  string(REGEX REPLACE "^[^/]+/include/" "" rel "${h}")
  list(APPEND public "${rel}")
endforeach()
set(errors 0)
foreach(h IN LISTS headers)
  file(STRINGS ${SODA_SOURCE_DIR}/${h} lines REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]*)\".*" "\\1" inc "${line}")
    if(NOT inc IN_LIST public)
      message(SEND_ERROR "${h}: includes \"${inc}\", which is not a public header (<folder>/include/soda/...)")
      math(EXPR errors "${errors} + 1")
    endif()
  endforeach()
endforeach()
list(LENGTH headers n)
if(errors EQUAL 0)
  message(STATUS "${n} public headers include public headers only")
else()
  message(FATAL_ERROR "${errors} include(s) of non-public headers in public headers")
endif()
