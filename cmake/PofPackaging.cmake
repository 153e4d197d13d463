# The SDK a controller project uses, and the Debian packages (CPack).
#
# Components: `runtime` (binaries, plot scripts, units, udev rules, sysusers, sysctl, /etc/pof
# configuration, the types jar) and `dev` (headers, static libraries, .lcm files, CMake package,
# pkg-config file). `cmake --install build --prefix P` installs both; `cpack` in the build
# directory makes pofkit_<v>_<arch>.deb and pofkit-dev_<v>_<arch>.deb (docs/deployment.md, "Install").
include(CMakePackageConfigHelpers)

set(POF_LCM_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/pofkit/lcmtypes)
set(POF_JAR_INSTALL_PATH share/java/pof_lcmtypes.jar)
set(POF_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/pofkit)

install(EXPORT pofkitTargets NAMESPACE pofkit:: DESTINATION ${POF_CMAKE_INSTALL_DIR} COMPONENT dev)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/pofkitConfig.cmake.in
  ${CMAKE_BINARY_DIR}/pofkitConfig.cmake
  INSTALL_DESTINATION ${POF_CMAKE_INSTALL_DIR}
  PATH_VARS POF_LCM_INSTALL_DIR POF_JAR_INSTALL_PATH)
# 0.x: minor versions may break the message types, so a client asks for the same minor version.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/pofkitConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/pofkitConfig.cmake ${CMAKE_BINARY_DIR}/pofkitConfigVersion.cmake
  DESTINATION ${POF_CMAKE_INSTALL_DIR} COMPONENT dev)

# The .pc file names the prefix, known only at install time (--prefix overrides the configured one).
install(CODE "
  set(CMAKE_INSTALL_INCLUDEDIR \"${CMAKE_INSTALL_INCLUDEDIR}\")
  set(CMAKE_INSTALL_LIBDIR \"${CMAKE_INSTALL_LIBDIR}\")
  set(POF_LCM_INSTALL_DIR \"${POF_LCM_INSTALL_DIR}\")
  set(PROJECT_DESCRIPTION \"${PROJECT_DESCRIPTION}\")
  set(PROJECT_VERSION \"${PROJECT_VERSION}\")
  configure_file(\"${CMAKE_CURRENT_LIST_DIR}/pofkit.pc.in\" \"${CMAKE_BINARY_DIR}/pofkit.pc\" @ONLY)"
  COMPONENT dev)
install(FILES ${CMAKE_BINARY_DIR}/pofkit.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)

# The example clients (C++, Python, MATLAB/Octave), with the SDK.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples COMPONENT dev)

# --- Debian packages --------------------------------------------------------------------------
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME pofkit)
set(CPACK_PACKAGE_VENDOR "pofkit")
set(CPACK_PACKAGE_CONTACT "pofkit maintainers <pofkit@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
# Install with DESTDIR=<staging> and prefix /usr (CPACK_INSTALL_PREFIX is the one DESTDIR mode
# uses), so the /etc/pof rule in deploy/ sees /usr.
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_SET_DESTDIR ON)
set(CPACK_STRIP_FILES ON)  # binaries without debug info (pof: 78 MB -> a few MB)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME pofkit)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "python3-matplotlib, liblcm-bin")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA
  ${CMAKE_BINARY_DIR}/debian/conffiles ${PROJECT_SOURCE_DIR}/deploy/debian/postinst)
set(CPACK_DEBIAN_DEV_PACKAGE_NAME pofkit-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "liblcm-dev, libeigen3-dev, libsodium-dev, libtomlplusplus-dev, pkg-config")
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
include(CPack)
