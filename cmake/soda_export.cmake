# soda_export(<target> <name> [<export set>]): makes library <target> part of
# the package, in export set sodaTargets (the default) or <export set>
# (sodaMpiTargets: the targets the installed config loads only when it finds
# MPI, cmake/sodaConfig.cmake.in).
#   - soda::<name>, an ALIAS for add_subdirectory users (the same name the
#     installed package's imported target has, so a consumer links the same
#     names either way);
#   - EXPORT_NAME <name>, so `cmake --install` exports it as soda::<name>;
#   - C++20 for its users too (the public headers need it);
#   - the installed include directory in its interface (its build-tree one,
#     <folder>/include, it sets itself inside $<BUILD_INTERFACE:...>);
#   - <folder>/include/ is installed (once, however many precisions use it)
#     and the target is added to the export set (cmake/install.cmake).
function(soda_export target name)
  set(export_set sodaTargets)
  if(ARGC GREATER 2)
    set(export_set ${ARGV2})
  endif()
  add_library(soda::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_include_directories(${target} INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  set_property(GLOBAL APPEND PROPERTY SODA_EXPORTED_TARGETS_${export_set} ${target})
  get_property(dirs GLOBAL PROPERTY SODA_PUBLIC_HEADER_DIRS)
  if(NOT "${CMAKE_CURRENT_SOURCE_DIR}/include" IN_LIST dirs)
    set_property(GLOBAL APPEND PROPERTY SODA_PUBLIC_HEADER_DIRS ${CMAKE_CURRENT_SOURCE_DIR}/include)
  endif()
endfunction()
