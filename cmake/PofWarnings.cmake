# One warnings policy for every target of the project.
# POF_WERROR turns warnings into errors; `.ci/run` and `./pofkit test` set it.
option(POF_WERROR "Treat compiler warnings as errors" OFF)

# Not -Wnull-dereference: with GCC 12 at -O2 it fires inside libstdc++ code inlined from CLI11's
# string splitting (a flow-analysis false positive in a system header we cannot fix); ASan/UBSan
# catch real null dereferences in the test build instead.
function(pof_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion
    -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual
    -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
  if(POF_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
