# Generates the LCM message types at build time (lcm-gen 1.3.1 has no CMake helpers; see
# ../shared/notes/lcm.md). Nothing generated is committed.
#
#   pof_lcm_types(TARGET <name> PACKAGE <pkg> SOURCES <a.lcm> ...)
#
# creates an INTERFACE library <name> whose include directory holds <pkg>/<type>.hpp, and, when a
# JDK is found, a jar `<name>.jar` in ${CMAKE_BINARY_DIR}/share/java that stock lcm-spy can load.
find_program(LCM_GEN_EXECUTABLE lcm-gen REQUIRED)
find_package(Java COMPONENTS Development QUIET)
find_file(LCM_JAR lcm.jar PATHS /usr/share/java NO_DEFAULT_PATH)

function(pof_lcm_types)
  cmake_parse_arguments(ARG "" "TARGET;PACKAGE" "SOURCES" ${ARGN})
  set(hpath ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/cpp)
  set(jpath ${CMAKE_CURRENT_BINARY_DIR}/lcmgen/java)
  set(headers "")
  set(javas "")
  set(abs_sources "")
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(type ${src} NAME_WE)
    list(APPEND headers ${hpath}/${ARG_PACKAGE}/${type}.hpp)
    list(APPEND javas ${jpath}/${ARG_PACKAGE}/${type}.java)
    list(APPEND abs_sources ${CMAKE_CURRENT_SOURCE_DIR}/${src})
  endforeach()

  # lcm-gen exits 0 even when it cannot write (see lcm.md), so the outputs are listed and the
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
  target_include_directories(${ARG_TARGET} SYSTEM INTERFACE ${hpath})
  target_link_libraries(${ARG_TARGET} INTERFACE PkgConfig::LCM)
  # LCM 1.3.1's lcm_coretypes.h decodes float/double by casting float* to int32_t* (and double* to
  # int64_t*): a strict-aliasing violation. GCC 12 at -O2 then drops the stores, and decoded floats
  # read back as 0 (seen: `pof export` printed every angle_t angle as 0 while the bytes were right).
  # Every user of the generated headers gets -fno-strict-aliasing; the e2e replay test catches it.
  target_compile_options(${ARG_TARGET} INTERFACE -fno-strict-aliasing)

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
