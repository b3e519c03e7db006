# sanitized_gtest(<target> <test source> <core sources...>): a gtest that compiles the core's
# sources itself (not the Release core library) with AddressSanitizer and UndefinedBehaviorSanitizer.
# No recovery: the first finding aborts the test. float-cast-overflow is not part of GCC's
# "undefined" group; a NaN or huge float converted to an integer (a bin index) is undefined.
set(FUZZ_HEADERS_DIR ${CMAKE_CURRENT_LIST_DIR})
function(sanitized_gtest target source)
  catkin_add_gtest(${target} ${source} ${ARGN})
  if(TARGET ${target})
    set(flags -fsanitize=address,undefined,float-cast-overflow -fno-sanitize-recover=all -fno-omit-frame-pointer)
    target_compile_options(${target} PRIVATE ${flags} -O1 -g -Wall -Wextra)
    target_link_options(${target} PRIVATE ${flags})
    target_include_directories(${target} PRIVATE ${FUZZ_HEADERS_DIR})
  endif()
endfunction()
