# What `cmake --install` puts where, the CMake package find_package(urslink) reads, and the .deb
# (`cpack -G DEB` in the build folder). Layout under the prefix (docs/deployment.md):
#   bin/                          the programs (RUNPATH $ORIGIN/../lib)
#   lib/liburslink_*.so.*         the libraries (cmake/UrsInstall.cmake)
#   lib/cmake/urslink/            urslinkConfig.cmake, its version file, the exported targets, PlanetIdl.cmake
#   include/urs/...               the libraries' headers; include/urslink/<lib>/ the generated ones
#   share/urslink/idl/            the IDL files, urs_options.proto, the omniidl Planet back-end
#   share/urslink/config/         example configurations of urs-sam, urs-rtc-manager and urs-bridge
#   share/urslink/tasks/          the CAMUS server's task files
#   share/urslink/fastdds-udp.xml the Fast DDS profile for spaces on networks without shared memory
#   share/urslink/web/            urs-gateway's dashboard (static files)
#   share/urslink/python/urslink/ the Python SDK (docs/sdk.md): PYTHONPATH=<prefix>/share/urslink/python
#   share/doc/urslink/examples/   the out-of-tree example project
#   lib/systemd/system/           the systemd units (deploy/systemd; they name /usr: the .deb's prefix)
#   libexec/urslink/              urs-entrypoint and urs-health, which the units run
#   share/urslink/systemd/        urslink.env, the example of /etc/urslink/urslink.env

# Programs. A new program joins this list (and so the package, the .deb and the images).
set(URS_INSTALLED_PROGRAMS urs-camus-server urs-sam urs-rtc-manager urs urs-bridge urs-lab urs-gateway)
foreach(program IN LISTS URS_INSTALLED_PROGRAMS)
  if(NOT TARGET ${program})
    message(FATAL_ERROR "cmake/UrsPackage.cmake: program ${program} is not a target: update URS_INSTALLED_PROGRAMS")
  endif()
endforeach()
install(TARGETS ${URS_INSTALLED_PROGRAMS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# Data the programs read at run time.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/idl/ DESTINATION ${URS_INSTALL_DATADIR}/idl
        FILES_MATCHING PATTERN "*.idl" PATTERN "*.proto" PATTERN "omniidl_planet/*.py"
        PATTERN "__pycache__" EXCLUDE)
install(FILES ${PROJECT_SOURCE_DIR}/services/sam/diagnostic.yaml DESTINATION ${URS_INSTALL_DATADIR}/config
        RENAME sam-diagnostic.yaml)
install(FILES ${PROJECT_SOURCE_DIR}/services/rtc-manager/example.yaml DESTINATION ${URS_INSTALL_DATADIR}/config
        RENAME rtc-example.yaml)
install(FILES ${PROJECT_SOURCE_DIR}/services/bridge/example.yaml DESTINATION ${URS_INSTALL_DATADIR}/config
        RENAME bridge-example.yaml)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/services/camus-server/tasks/ DESTINATION ${URS_INSTALL_DATADIR}/tasks
        FILES_MATCHING PATTERN "*.yaml")
install(FILES ${PROJECT_SOURCE_DIR}/compose/fastdds-udp.xml DESTINATION ${URS_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/services/gateway/web/ DESTINATION ${URS_INSTALL_DATADIR}/web)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples
        PATTERN "__pycache__" EXCLUDE)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/python/urslink DESTINATION ${URS_INSTALL_DATADIR}/python
        FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)

# The systemd units (generated with deploy/services/urs-services from deploy/services/services.yaml) and
# the entry point they run: the images' urs-entrypoint, which turns the environment into flags.
file(GLOB urs_systemd_units CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/deploy/systemd/*.service)
install(FILES ${urs_systemd_units} DESTINATION lib/systemd/system)
install(PROGRAMS ${PROJECT_SOURCE_DIR}/deploy/images/bin/urs-entrypoint ${PROJECT_SOURCE_DIR}/deploy/images/bin/urs-health
        DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/urslink)
install(FILES ${PROJECT_SOURCE_DIR}/deploy/systemd/urslink.env DESTINATION ${URS_INSTALL_DATADIR}/systemd)

# find_package(urslink): the exported libraries as urslink::<name>, their dependencies, and the
# IDL functions of idl/PlanetIdl.cmake.
install(EXPORT urslinkTargets NAMESPACE urslink:: DESTINATION ${URS_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/urslinkConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/urslinkConfig.cmake
                              INSTALL_DESTINATION ${URS_INSTALL_CMAKEDIR}
                              PATH_VARS URS_INSTALL_DATADIR)
# While the major version is 0 a minor version may break the API: a user asking for 0.1 gets 0.1.x.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(urs_compatibility SameMinorVersion)
else()
  set(urs_compatibility SameMajorVersion)
endif()
write_basic_package_version_file(${PROJECT_BINARY_DIR}/urslinkConfigVersion.cmake
                                 COMPATIBILITY ${urs_compatibility})
install(FILES ${PROJECT_BINARY_DIR}/urslinkConfig.cmake ${PROJECT_BINARY_DIR}/urslinkConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/idl/PlanetIdl.cmake
        DESTINATION ${URS_INSTALL_CMAKEDIR})

# The .deb: `cpack -G DEB` in the build folder writes urslink_<version>_<arch>.deb, installing
# under /usr. Depends: the Debian packages of the shared libraries the programs link (found by
# dpkg-shlibdeps), plus what they run or read: omniidl and Python for loading IDL at run time,
# the speech devices' data. Building against the package needs the -dev packages in Suggests;
# the Python SDK needs python3-protobuf (and protobuf-compiler to load IDL files).
set(CPACK_PACKAGE_NAME urslink)
set(CPACK_PACKAGE_VENDOR "URSLink")
set(CPACK_PACKAGE_CONTACT "URSLink maintainers <urslink@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGE_DESCRIPTION
    "URSLink makes RT-Middleware (OpenRTM-aist) and CAMUS robot spaces usable from each other and links\n"
    "spaces over DDS: the CAMUS server, SAM host, RT-Component manager, bridge and command-line client,\n"
    "their libraries and headers, and the CMake package find_package(urslink).")
string(REPLACE ";" "" CPACK_PACKAGE_DESCRIPTION "${CPACK_PACKAGE_DESCRIPTION}")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_STRIP_FILES ON)  # programs and libraries without their debug information
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "omniidl, python3, espeak-ng-data, pocketsphinx-en-us")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "omniorb-nameserver")
# postinst: the system user urslink the units run as, /etc/urslink, and systemd told of the units.
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/deploy/systemd/postinst)
set(CPACK_DEBIAN_PACKAGE_SUGGESTS
    "python3-protobuf, cmake, pkg-config, g++, libprotobuf-dev, protobuf-compiler, libspdlog-dev, libyaml-cpp-dev, libomniorb4-dev, prometheus-cpp-dev")
include(CPack)
