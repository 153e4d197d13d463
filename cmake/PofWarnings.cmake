# One warnings policy for every target of the project (issue 2).
# POF_WERROR turns warnings into errors; `.ci/run` and `./pofkit test` set it.
option(POF_WERROR "Treat compiler warnings as errors" OFF)

function(pof_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion
    -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual
    -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
  if(POF_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
