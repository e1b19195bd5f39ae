# autoscan_module(<name> [DEPS <autoscan modules...>] [LIBS <public third-party targets>]
#                 [PRIVATE_LIBS <private third-party targets>])
# Builds src/autoscan/<name>/*.cpp into the static library autoscan_<name> with the alias
# autoscan::<name>. Headers are included as "autoscan/<name>/<file>.hpp".
function(autoscan_module name)
  cmake_parse_arguments(ARG "" "" "DEPS;LIBS;PRIVATE_LIBS" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  add_library(autoscan_${name} STATIC ${_srcs})
  add_library(autoscan::${name} ALIAS autoscan_${name})
  target_include_directories(autoscan_${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
                                                     $<INSTALL_INTERFACE:include>)
  target_compile_features(autoscan_${name} PUBLIC cxx_std_20)
  # EXPORT_NAME: the installed package names it autoscan::<name> too (autoscanConfig.cmake).
  set_target_properties(autoscan_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${name})
  foreach(d IN LISTS ARG_DEPS)
    target_link_libraries(autoscan_${name} PUBLIC autoscan::${d})
  endforeach()
  target_link_libraries(autoscan_${name} PUBLIC ${ARG_LIBS} PRIVATE ${ARG_PRIVATE_LIBS}
                                                               $<BUILD_INTERFACE:autoscan_warnings>)
  if(AUTOSCAN_FUZZ)
    target_compile_options(autoscan_${name} PRIVATE ${AUTOSCAN_FUZZ_FLAGS})
    if(NOT name IN_LIST AUTOSCAN_FUZZ_MODULES)
      target_compile_options(autoscan_${name} PRIVATE -O0 -g0)  # reached only by option checks: build fast
    endif()
  endif()
  if(AUTOSCAN_INSTALL)
    install(TARGETS autoscan_${name} EXPORT autoscanTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/autoscan/${name}
            FILES_MATCHING PATTERN "*.hpp")
  endif()
endfunction()

# autoscan_test(<module> [LIBS ...]): tests/<module>/*.cpp into test_<module>, registered with CTest.
function(autoscan_test module)
  cmake_parse_arguments(ARG "" "" "LIBS" ${ARGN})
  file(GLOB _srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${module}/*.cpp)
  if(NOT _srcs)
    return()
  endif()
  add_executable(test_${module} ${_srcs})
  target_link_libraries(test_${module} PRIVATE autoscan::${module} ${ARG_LIBS} GTest::gtest_main GTest::gmock
                                               autoscan_test_support autoscan_warnings)
  target_compile_definitions(test_${module} PRIVATE AUTOSCAN_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data"
                                                    AUTOSCAN_MODELS_DIR="${PROJECT_SOURCE_DIR}/data/models")
  gtest_discover_tests(test_${module} DISCOVERY_TIMEOUT 60 PROPERTIES LABELS ${module})
endfunction()
