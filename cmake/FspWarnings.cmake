# fsp_set_warnings(target): warnings for our own code only (third-party headers are SYSTEM).
function(fsp_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wcast-align -Woverloaded-virtual -Wnull-dereference)
  if(FSP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# fsp_add_library(name [INSTALL] SOURCES ... DEPS ...): one library per folder, public headers in
# include/. INSTALL: `cmake --install` puts the library and its headers in place and exports it as
# fsp::<name without the fsp_ prefix> (fsp::common, fsp::pipeline, ...; cmake/fspConfig.cmake.in).
# The same name is an alias in the build tree.
function(fsp_add_library name)
  cmake_parse_arguments(ARG "INSTALL" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                            $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  fsp_set_warnings(${name})
  string(REGEX REPLACE "^fsp_" "" export_name ${name})
  set_target_properties(${name} PROPERTIES EXPORT_NAME ${export_name})
  add_library(fsp::${export_name} ALIAS ${name})
  if(ARG_INSTALL)
    install(TARGETS ${name} EXPORT fspTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
    install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endfunction()
