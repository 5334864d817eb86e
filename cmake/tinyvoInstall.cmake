# SPDX-License-Identifier: Apache-2.0
# Install rules shared by every target (included by the top CMakeLists.txt after lib/ and port/):
#   <libdir>/cmake/tinyvo/   CMake package: find_package(tinyvo [COMPONENTS port v4l2]) gives
#                            tinyvo::tinyvo, tinyvo::port, tinyvo::v4l2 (those that were built) and
#                            tinyvo_MODELS_DIR
#   <libdir>/pkgconfig/      tinyvo.pc, tinyvo-port.pc, tinyvo-v4l2.pc, relocatable (prefix from ${pcfiledir})
#   share/tinyvo/models/     the shipped weights files (*.tvonn) and their model card
#   share/doc/tinyvo/        LICENSE
include(CMakePackageConfigHelpers)
set(TVO_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/tinyvo)
set(TVO_MODELS_DIR ${CMAKE_INSTALL_DATADIR}/tinyvo/models)

install(EXPORT tinyvoTargets NAMESPACE tinyvo:: DESTINATION ${TVO_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/tinyvoConfig.cmake.in
  ${PROJECT_BINARY_DIR}/tinyvoConfig.cmake
  INSTALL_DESTINATION ${TVO_CMAKE_DIR}
  PATH_VARS CMAKE_INSTALL_INCLUDEDIR TVO_MODELS_DIR)
# While MAJOR is 0 a MINOR release may break the API (version.h): only the same MAJOR.MINOR is compatible.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(TVO_COMPAT SameMinorVersion)
else()
  set(TVO_COMPAT SameMajorVersion)
endif()
write_basic_package_version_file(${PROJECT_BINARY_DIR}/tinyvoConfigVersion.cmake COMPATIBILITY ${TVO_COMPAT})
install(FILES ${PROJECT_BINARY_DIR}/tinyvoConfig.cmake ${PROJECT_BINARY_DIR}/tinyvoConfigVersion.cmake
  DESTINATION ${TVO_CMAKE_DIR})

# pkg-config: prefix is found from the .pc file's own folder, so the installed tree can be moved or
# installed with `cmake --install --prefix` elsewhere than the configure-time prefix.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(TVO_PC_PREFIX "${CMAKE_INSTALL_PREFIX}") # an absolute libdir cannot be relocated
  set(TVO_PC_LIBDIR "${CMAKE_INSTALL_LIBDIR}")
else()
  file(RELATIVE_PATH TVO_PC_UP "/p/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/p")
  string(REGEX REPLACE "/$" "" TVO_PC_UP "${TVO_PC_UP}")
  set(TVO_PC_PREFIX "\${pcfiledir}/${TVO_PC_UP}")
  set(TVO_PC_LIBDIR "\${prefix}/${CMAKE_INSTALL_LIBDIR}")
endif()
foreach(dir INCLUDEDIR DATADIR)
  if(IS_ABSOLUTE "${CMAKE_INSTALL_${dir}}")
    set(TVO_PC_${dir} "${CMAKE_INSTALL_${dir}}")
  else()
    set(TVO_PC_${dir} "\${prefix}/${CMAKE_INSTALL_${dir}}")
  endif()
endforeach()
set(TVO_PC_FILES tinyvo)
if(TARGET tinyvo_port)
  list(APPEND TVO_PC_FILES tinyvo-port)
endif()
if(TARGET tinyvo_v4l2)
  list(APPEND TVO_PC_FILES tinyvo-v4l2)
endif()
foreach(pc ${TVO_PC_FILES})
  configure_file(${PROJECT_SOURCE_DIR}/cmake/${pc}.pc.in ${PROJECT_BINARY_DIR}/${pc}.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/${pc}.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endforeach()

file(GLOB TVO_MODEL_FILES ${PROJECT_SOURCE_DIR}/models/*.tvonn)
install(FILES ${TVO_MODEL_FILES} ${PROJECT_SOURCE_DIR}/models/MODEL_CARD.md DESTINATION ${TVO_MODELS_DIR})
if(EXISTS ${PROJECT_SOURCE_DIR}/LICENSE)
  install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})
endif()
