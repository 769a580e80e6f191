# What keeps a cold build short (CONTRIBUTING.md, "Build time"; measured by deploy/build-time.sh).
# Each is a cache option, so a build folder may turn it off.
#
# URS_DEBUG_INFO  lines | full    (default lines)
#   Debug information of RelWithDebInfo builds. lines (-g1): function names and line tables, which
#   is what a backtrace needs (gdb's bt, sanitizer reports and addr2line give function, file and
#   line), without variables' locations; on the heaviest files a third less compile time than -g
#   and objects a quarter the size. full: CMake's -g, for stepping through optimized code with its
#   variables (or use CMAKE_BUILD_TYPE=Debug).
# URS_LINKER  auto | mold | lld | gold | bfd    (default auto)
#   The linker the compiler driver uses (-fuse-ld=). auto takes mold (Debian package mold, from
#   deploy/install-deps.sh), else lld, else the toolchain's default (bfd); a linker named
#   explicitly must work, or configure fails.
# URS_TEST_OPTIMIZATION  a -O flag    (default -O1)
#   Optimization of the test programs' own sources (urs_gtest() and urs_test_pch): the code under
#   test is in the libraries, built with the build type's flags (-O2); a test's sources are mostly
#   GoogleTest's expanded macros, which -O2 takes a third longer to compile than -O1. Empty: the
#   build type's flags alone.
# URS_PCH  ON | OFF    (default ON)
#   Precompiled headers for the test programs: every urs_gtest() program reuses the one of
#   urs_test_pch (tests/CMakeLists.txt): the standard library, GoogleTest and GoogleMock, Protobuf's
#   message and descriptor headers. A test source still includes what it uses: the lint step
#   (deploy/lint.sh) parses each source without the precompiled header.

set(URS_DEBUG_INFO lines CACHE STRING "Debug information of RelWithDebInfo builds: lines (-g1) or full (-g)")
set_property(CACHE URS_DEBUG_INFO PROPERTY STRINGS lines full)
if(URS_DEBUG_INFO STREQUAL "lines")
  # After CMAKE_CXX_FLAGS_RELWITHDEBINFO's -g on the command line: the last -g level wins.
  add_compile_options($<$<CONFIG:RelWithDebInfo>:-g1>)
elseif(NOT URS_DEBUG_INFO STREQUAL "full")
  message(FATAL_ERROR "URS_DEBUG_INFO: '${URS_DEBUG_INFO}' is neither lines nor full")
endif()

set(URS_LINKER auto CACHE STRING "Linker: auto (mold, else lld, else the default), mold, lld, gold or bfd")
set_property(CACHE URS_LINKER PROPERTY STRINGS auto mold lld gold bfd)
include(CheckLinkerFlag)
if(URS_LINKER STREQUAL "auto")
  set(urs_linker_choices mold lld)
elseif(URS_LINKER MATCHES "^(mold|lld|gold|bfd)$")
  set(urs_linker_choices ${URS_LINKER})
else()
  message(FATAL_ERROR "URS_LINKER: '${URS_LINKER}' is not one of auto, mold, lld, gold, bfd")
endif()
set(urs_linker_used "")
foreach(linker IN LISTS urs_linker_choices)
  check_linker_flag(CXX -fuse-ld=${linker} URS_LINKER_${linker}_WORKS)
  if(URS_LINKER_${linker}_WORKS)
    set(urs_linker_used ${linker})
    break()
  endif()
endforeach()
if(urs_linker_used STREQUAL "mold")
  # --no-fork: mold otherwise returns from a child process that the launcher of
  # deploy/build-time.sh cannot account for; the cost is its clean-up in the waiting process.
  add_link_options(-fuse-ld=mold LINKER:--no-fork)
  message(STATUS "Linker: mold")
elseif(urs_linker_used)
  add_link_options(-fuse-ld=${urs_linker_used})
  message(STATUS "Linker: ${urs_linker_used}")
elseif(URS_LINKER STREQUAL "auto")
  message(STATUS "Linker: the toolchain's default (neither mold nor lld found; deploy/install-deps.sh installs mold)")
else()
  message(FATAL_ERROR "URS_LINKER=${URS_LINKER}: the compiler cannot link with -fuse-ld=${URS_LINKER}")
endif()

set(URS_TEST_OPTIMIZATION -O1 CACHE STRING "Optimization of the test programs' own sources (empty: the build type's)")
if(URS_TEST_OPTIMIZATION AND NOT URS_TEST_OPTIMIZATION MATCHES "^-O[0-3gs]$")
  message(FATAL_ERROR "URS_TEST_OPTIMIZATION: '${URS_TEST_OPTIMIZATION}' is not -O0, -O1, -O2, -O3, -Og or -Os")
endif()

option(URS_PCH "Precompiled headers for the test programs" ON)
