# `cmake --install <build> [--prefix P]`: the libraries soda_export() named,
# their public headers (<folder>/include/soda/...; never <folder>/src), the
# CLI when it was built, and the CMake package:
#   P/lib/cmake/soda/sodaConfig.cmake         find_package(soda): finds the dependencies
#   P/lib/cmake/soda/sodaConfigVersion.cmake  same major.minor is compatible (0.x: no promise across minors)
#   P/lib/cmake/soda/sodaTargets*.cmake       the imported targets soda::runtime, soda::runtime_double, ...
#   P/lib/cmake/soda/sodaMpiTargets*.cmake    soda::mpi, soda::mpi_double (built with SODA_MPI)
include(CMakePackageConfigHelpers)

set(SODA_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/soda)

get_property(soda_public_header_dirs GLOBAL PROPERTY SODA_PUBLIC_HEADER_DIRS)

# sodaTargets: every library; sodaMpiTargets: soda::mpi{,_double} (SODA_MPI),
# which the config loads only where it finds MPI.
foreach(export_set IN ITEMS sodaTargets sodaMpiTargets)
  get_property(soda_exported_targets GLOBAL PROPERTY SODA_EXPORTED_TARGETS_${export_set})
  if(NOT soda_exported_targets)
    continue()
  endif()
  install(TARGETS ${soda_exported_targets}
          EXPORT ${export_set}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(EXPORT ${export_set} NAMESPACE soda:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/soda)
endforeach()
foreach(dir IN LISTS soda_public_header_dirs)
  install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
endforeach()
if(NOT SODA_LIBRARIES_ONLY)
  install(TARGETS soda RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  if(SODA_BUILD_DOUBLE)
    install(TARGETS soda-double RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endif()


# What the installed config must find again: Bullet's pkg-config modules of
# the precisions built (the others are not installed).
set(SODA_PACKAGE_BULLET_MODULES "SODA_BULLET_FLOAT=bullet")
if(SODA_BUILD_DOUBLE)
  list(APPEND SODA_PACKAGE_BULLET_MODULES "SODA_BULLET_DOUBLE=bullet-float64")
endif()
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/sodaConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/sodaConfig.cmake
                              INSTALL_DESTINATION ${SODA_INSTALL_CMAKEDIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/sodaConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/sodaConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/sodaConfigVersion.cmake
        DESTINATION ${SODA_INSTALL_CMAKEDIR})
