# fsp_set_warnings(target): warnings for our own code only (third-party headers are SYSTEM).
function(fsp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wcast-align -Woverloaded-virtual -Wnull-dereference)
  if(FSP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# fsp_add_library(name SOURCES ... DEPS ...): one library per folder, public headers in include/.
function(fsp_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  fsp_set_warnings(${name})
endfunction()
