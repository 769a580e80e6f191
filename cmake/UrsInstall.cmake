# How URSLink's libraries and programs are built to be installed (docs/deployment.md, CONTRIBUTING.md).
#
# Every library under services/lib and devices/, and every library of generated code, is SHARED:
# a service agent loaded as a plug-in into urs-sam or urs-rtc-manager links the same libraries as
# its host, and Protobuf's generated code linked statically into both would register its
# descriptors twice. Libraries private to one program (urs_camus, urs_sam_lib, ...) stay STATIC;
# a static library linked into a shared one needs POSITION_INDEPENDENT_CODE.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# Installed programs and libraries find the package's libraries next to them, wherever the tree
# is installed (/usr from the .deb, /opt/urslink in the images, any --prefix).
file(RELATIVE_PATH urs_bin_to_lib ${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}
     ${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR})
set(CMAKE_INSTALL_RPATH "$ORIGIN/${urs_bin_to_lib}")

set(URS_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/urslink)
set(URS_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/urslink)
# The omniidl Planet back-end seen from the libraries' folder: urs::schema's load_idl() finds the
# installed back-end there (services/lib/schema/src/idl_loader.cpp).
file(RELATIVE_PATH URS_LIB_TO_PLANET_BACKEND ${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}
     ${CMAKE_INSTALL_PREFIX}/${URS_INSTALL_DATADIR}/idl/omniidl_planet)

# 0.x releases may break the ABI with every minor version.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(URS_SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
else()
  set(URS_SOVERSION ${PROJECT_VERSION_MAJOR})
endif()

# urs_install_library(<target> [HEADERS <dir>])
#   Makes the SHARED library <target> part of the installed package:
#   - lib/liburslink_<name>.so.<version> (SOVERSION major.minor while the major version is 0),
#     <name> being the target's name without its urs_ prefix;
#   - exported as urslink::<name> by find_package(urslink), with the same name as an alias in the
#     build tree (every library is: an exported library's private dependencies must be too);
#   - public headers: HEADERS <dir> (hand-written, e.g. include/) is the library's PUBLIC include
#     folder in the build tree and is installed into include/; a library of generated code
#     (urs_proto_library, urs_idl_library, urs_corba_idl_library, urs_dds_idl_library) installs
#     its generated headers into include/urslink/<name>/.
function(urs_install_library target)
  cmake_parse_arguments(ARG "" "HEADERS" "" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "urs_install_library(${target}): unexpected arguments '${ARG_UNPARSED_ARGUMENTS}'")
  endif()
  get_target_property(type ${target} TYPE)
  if(NOT type STREQUAL "SHARED_LIBRARY")
    message(FATAL_ERROR "urs_install_library(${target}): the package holds shared libraries only (${target} is ${type})")
  endif()
  string(REGEX REPLACE "^urs_" "" name ${target})
  set_target_properties(${target} PROPERTIES
    OUTPUT_NAME urslink_${name}
    EXPORT_NAME ${name}
    VERSION ${PROJECT_VERSION}
    SOVERSION ${URS_SOVERSION})
  add_library(urslink::${name} ALIAS ${target})

  install(TARGETS ${target} EXPORT urslinkTargets LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  if(ARG_HEADERS)
    get_filename_component(headers ${ARG_HEADERS} ABSOLUTE)
    target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${headers}>
                                                $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    install(DIRECTORY ${headers}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
  get_target_property(generated ${target} URS_GENERATED_HEADERS)
  if(generated)
    set(generated_dir ${CMAKE_INSTALL_INCLUDEDIR}/urslink/${name})
    target_include_directories(${target} SYSTEM PUBLIC $<INSTALL_INTERFACE:${generated_dir}>)
    install(FILES ${generated} DESTINATION ${generated_dir})
  endif()
endfunction()
