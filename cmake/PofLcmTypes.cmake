# Generates the LCM message types at build time (lcm-gen 1.3.1 has no CMake helpers; see
# docs/lcm.md). Nothing generated is committed.
#
#   pof_lcm_types(TARGET <name> PACKAGE <pkg> SOURCES <a.lcm> ...)
#
# creates
#   - an INTERFACE library <name> whose include directory holds <pkg>/<type>.hpp (C++),
#   - a static library <name>_c from lcm-gen's C output (<pkg>_<type>.h/.c) for C clients,
#   - lcm-gen's Python classes in ${CMAKE_BINARY_DIR}/python/<pkg> (the pofkit Python package's types),
#   - when a JDK is found, a jar `<name>.jar` in ${CMAKE_BINARY_DIR}/share/java that stock lcm-spy
#     (and MATLAB/Octave through Java) can load.
# All of them, and the .lcm sources, are installed as part of the SDK (component `dev`; the jar goes
# with the runtime, which lcm-spy uses) and exported to the package config (cmake/pofkitConfig.cmake.in).
find_program(LCM_GEN_EXECUTABLE lcm-gen REQUIRED)
find_package(Java COMPONENTS Development QUIET)
find_file(LCM_JAR lcm.jar PATHS /usr/share/java NO_DEFAULT_PATH)
# Debian's path for Python 3 packages of any Python 3 version (a non-/usr prefix: add it to PYTHONPATH).
set(POF_PYTHON_INSTALL_DIR lib/python3/dist-packages)

function(pof_lcm_types)
  cmake_parse_arguments(ARG "" "TARGET;PACKAGE" "SOURCES" ${ARGN})
  set(hpath ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/cpp)
  set(jpath ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/java)
  set(cpath ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/c)
  set(headers "")
  set(c_files "")
  set(javas "")
  set(abs_sources "")
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(type ${src} NAME_WE)
    list(APPEND headers ${hpath}/${ARG_PACKAGE}/${type}.hpp)
    list(APPEND c_files ${cpath}/${ARG_PACKAGE}_${type}.c ${cpath}/${ARG_PACKAGE}_${type}.h)
    list(APPEND javas ${jpath}/${ARG_PACKAGE}/${type}.java)
    list(APPEND abs_sources ${CMAKE_CURRENT_SOURCE_DIR}/${src})
  endforeach()

  # lcm-gen exits 0 even when it cannot write (docs/lcm.md, "Packaging"), so the outputs are listed and the
  # directory is made first; a missing header then fails the build at the consumer.
  add_custom_command(
    OUTPUT ${headers}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${hpath}
    COMMAND ${LCM_GEN_EXECUTABLE} -x --cpp-std c++11 --cpp-hpath ${hpath} ${abs_sources}
    DEPENDS ${abs_sources}
    COMMENT "lcm-gen (C++) for package ${ARG_PACKAGE}"
    VERBATIM)
  add_custom_target(${ARG_TARGET}_gen DEPENDS ${headers})
  add_library(${ARG_TARGET} INTERFACE)
  add_dependencies(${ARG_TARGET} ${ARG_TARGET}_gen)
  # SYSTEM: generated code is not ours to warn about (it trips -Wold-style-cast and friends).
  target_include_directories(${ARG_TARGET} SYSTEM INTERFACE
    $<BUILD_INTERFACE:${hpath}> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${ARG_TARGET} INTERFACE PkgConfig::LCM)
  # LCM 1.3.1's lcm_coretypes.h decodes float/double by casting float* to int32_t* (and double* to
  # int64_t*): a strict-aliasing violation. GCC 12 at -O2 then drops the stores, and decoded floats
  # read back as 0 (seen: `pof export` printed every angle_t angle as 0 while the bytes were right).
  # Every user of the generated headers gets -fno-strict-aliasing; the e2e replay test catches it.
  target_compile_options(${ARG_TARGET} INTERFACE -fno-strict-aliasing)
  set_target_properties(${ARG_TARGET} PROPERTIES EXPORT_NAME lcmtypes)
  install(TARGETS ${ARG_TARGET} EXPORT pofkitTargets)
  install(DIRECTORY ${hpath}/${ARG_PACKAGE} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)
  install(FILES ${abs_sources} DESTINATION ${CMAKE_INSTALL_DATADIR}/pofkit/lcmtypes COMPONENT dev)

  # C: one .c/.h pair per type, compiled into a static library (PIC, so a client's shared library
  # can link it). The same -fno-strict-aliasing applies: lcm_coretypes.h is shared with C++.
  add_custom_command(
    OUTPUT ${c_files}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${cpath}
    COMMAND ${LCM_GEN_EXECUTABLE} -c --c-cpath ${cpath} --c-hpath ${cpath} ${abs_sources}
    DEPENDS ${abs_sources}
    COMMENT "lcm-gen (C) for package ${ARG_PACKAGE}"
    VERBATIM)
  add_library(${ARG_TARGET}_c STATIC ${c_files})
  set_target_properties(${ARG_TARGET}_c PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME lcmtypes_c)
  target_include_directories(${ARG_TARGET}_c SYSTEM PUBLIC
    $<BUILD_INTERFACE:${cpath}> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${ARG_TARGET}_c PUBLIC PkgConfig::LCM)
  target_compile_options(${ARG_TARGET}_c PUBLIC -fno-strict-aliasing)
  install(TARGETS ${ARG_TARGET}_c EXPORT pofkitTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
  list(FILTER c_files INCLUDE REGEX "\\.h$")
  install(FILES ${c_files} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev)

  # Python: lcm-gen's classes (package <pkg>), used by the pofkit Python package (lcmtypes/python/pofkit),
  # which speaks the log format and udpm itself (Debian ships no LCM Python module).
  set(ppath ${CMAKE_BINARY_DIR}/python)
  set(pys ${ppath}/${ARG_PACKAGE}/__init__.py)
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(type ${src} NAME_WE)
    list(APPEND pys ${ppath}/${ARG_PACKAGE}/${type}.py)
  endforeach()
  add_custom_command(
    OUTPUT ${pys}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${ppath}
    COMMAND ${LCM_GEN_EXECUTABLE} -p --ppath ${ppath} ${abs_sources}
    DEPENDS ${abs_sources}
    COMMENT "lcm-gen (Python) for package ${ARG_PACKAGE}"
    VERBATIM)
  add_custom_target(${ARG_TARGET}_py ALL DEPENDS ${pys})
  install(DIRECTORY ${ppath}/${ARG_PACKAGE} DESTINATION ${POF_PYTHON_INSTALL_DIR})

  if(Java_JAVAC_EXECUTABLE AND Java_JAR_EXECUTABLE AND LCM_JAR)
    set(classes ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/classes)
    set(jar ${CMAKE_BINARY_DIR}/share/java/${ARG_TARGET}.jar)
    add_custom_command(
      OUTPUT ${jar}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${jpath} ${classes} ${CMAKE_BINARY_DIR}/share/java
      COMMAND ${LCM_GEN_EXECUTABLE} -j --jpath ${jpath} ${abs_sources}
      COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -cp ${LCM_JAR} -d ${classes} ${javas}
      COMMAND ${Java_JAR_EXECUTABLE} cf ${jar} -C ${classes} .
      DEPENDS ${abs_sources}
      COMMENT "lcm-gen (Java) + javac + jar for lcm-spy: ${ARG_TARGET}.jar"
      VERBATIM)
    add_custom_target(${ARG_TARGET}_jar ALL DEPENDS ${jar})
    install(FILES ${jar} DESTINATION share/java)
  else()
    message(STATUS "No JDK or lcm.jar: the LCM types jar for lcm-spy is not built")
  endif()
endfunction()
