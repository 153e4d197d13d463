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

# The static libraries without debug info (dh_strip's options for them): the release preset's
# line tables made pofkit-dev 65 MB. Only when installing stripped (POF_INSTALL_STRIP, cpack).
install(CODE "
  if(CMAKE_INSTALL_DO_STRIP)
    file(GLOB pof_static_libs \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/libpof*.a\")
    foreach(lib IN LISTS pof_static_libs)
      execute_process(COMMAND \"${CMAKE_STRIP}\" --strip-debug --remove-section=.comment --remove-section=.note
        --enable-deterministic-archives \"\${lib}\" RESULT_VARIABLE rc)
      if(NOT rc EQUAL 0)
        message(FATAL_ERROR \"strip --strip-debug \${lib} failed (\${rc})\")
      endif()
    endforeach()
  endif()" COMPONENT dev)

# --- Debian packages --------------------------------------------------------------------------
set(POF_DEB_MAINTAINER "pofkit maintainers <maintainers@users.noreply.h-seed-4646262e.example>"
  CACHE STRING "Maintainer of the .deb packages (name <email>)")
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME pofkit)
set(CPACK_PACKAGE_VENDOR "pofkit")
set(CPACK_PACKAGE_CONTACT "${POF_DEB_MAINTAINER}")

# Debian's per-package documents, for each package: copyright, a changelog (a native package's,
# changelog.gz) and, for pofkit, the README. gzip -n: no name or time stamp, so builds compare.
set(pof_changelog_date_fmt "%a, %d %b %Y %H:%M:%S +0000")
string(TIMESTAMP pof_changelog_date "${pof_changelog_date_fmt}" UTC)
foreach(pkg pofkit pofkit-dev)
  set(dir ${CMAKE_BINARY_DIR}/debian/doc/${pkg})
  file(MAKE_DIRECTORY ${dir})
  file(WRITE ${dir}/changelog "${pkg} (${PROJECT_VERSION}) bookworm; urgency=medium

  * pofkit ${PROJECT_VERSION}, built from its source tree with CPack.

 -- ${POF_DEB_MAINTAINER}  ${pof_changelog_date}
")
  execute_process(COMMAND gzip -9nf ${dir}/changelog RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "gzip of ${dir}/changelog failed")
  endif()
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/copyright ${CMAKE_BINARY_DIR}/debian/doc/pofkit/changelog.gz
  ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/pofkit COMPONENT runtime)
install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/copyright ${CMAKE_BINARY_DIR}/debian/doc/pofkit-dev/changelog.gz
  DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/pofkit-dev COMPONENT dev)
# What lintian flags on purpose, each with its reason in the file.
install(FILES ${PROJECT_SOURCE_DIR}/deploy/debian/lintian/pofkit-dev
  DESTINATION ${CMAKE_INSTALL_DATADIR}/lintian/overrides COMPONENT dev)
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
# A synopsis of at most 80 characters, then the extended description (Debian policy 3.4), per
# package. CPack puts CPACK_PACKAGE_DESCRIPTION_SUMMARY (else the project's description, too long
# for a synopsis) before it unless the summary is CPack's own default, so it is set to that.
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${CPACK_PACKAGE_NAME} built using CMake")
set(CPACK_DEBIAN_RUNTIME_DESCRIPTION "POF knee-angle sensing: DAQ and compensation daemons, recorder
pofkit acquires polymer-optical-fibre (POF) curvature sensors on an
exoskeleton knee from a USB DAQ (NI USB-6008/6009, MCC USB-1208LS),
compensates their hysteresis online and publishes the knee angle and
per-cycle statistics over LCM.
.
This package holds the daemons pof-daqd and pof-compensatord, the pof
command line (simulate, calibrate, compensate, record, spy, dash, export), their
systemd units (pof.target), udev rules, the system user, the LCM
socket-buffer sysctl, the message types for Java and Python, and the plot
scripts.")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
# The Python package (pofkit.log reads logs into NumPy arrays) is for /usr/bin/python3 only
# (dist-packages): python3 and NumPy are dependencies; matplotlib only draws the plots.
# `pof dash` serves Debian's Chart.js to the browser (never fetched at run time).
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "python3, python3-numpy, libjs-chart.js")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "python3-matplotlib, liblcm-bin")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA ${CMAKE_BINARY_DIR}/debian/conffiles
  ${PROJECT_SOURCE_DIR}/deploy/debian/postinst ${PROJECT_SOURCE_DIR}/deploy/debian/prerm
  ${PROJECT_SOURCE_DIR}/deploy/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)  # maintainer scripts 0755, the rest 0644
set(CPACK_DEBIAN_DEV_PACKAGE_NAME pofkit-dev)
set(CPACK_DEBIAN_DEV_DESCRIPTION "POF knee-angle sensing: SDK for exoskeleton controller clients
The development files of pofkit for a controller that consumes its angles:
the LCM message types (C and C++ headers, a C library, the .lcm files),
the pure sensor model (libpof_core), the calibration file reader
(libpof_calibration_io, libpof_base), the authenticated mode's verifier and
key files (libpof_auth), a CMake package (find_package(pofkit)), a
pkg-config file and example clients.")
# The SDK is the runtime's exact version: the types jar, the .lcm files and the headers of one
# release describe one wire format.
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
  "pofkit (= ${PROJECT_VERSION}), liblcm-dev, libeigen3-dev, libsodium-dev, libtomlplusplus-dev, pkg-config")
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
include(CPack)
