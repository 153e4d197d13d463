# pof_benchmark(<name> SOURCES <files...> [LIBS <targets...>] [PLAIN])
# One benchmark program of a folder's bench/: Google Benchmark unless PLAIN (a program that prints
# its own figures, e.g. accuracy against the simulator). Built with POF_BUILD_BENCHMARKS; figures go
# to BENCHMARKS.md with the command that produced them.
function(pof_benchmark name)
  if(NOT POF_BUILD_BENCHMARKS)
    return()
  endif()
  cmake_parse_arguments(ARG "PLAIN" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS})
  if(NOT ARG_PLAIN)
    target_link_libraries(${name} PRIVATE benchmark::benchmark)
  endif()
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/generators/include)  # generators
  pof_set_warnings(${name})
endfunction()
