# Packages (CPack, .deb) and what they install besides the programs (whose install() lines sit beside
# their targets). One component per package:
#   edge -> voxcap-edge (amd64, or arm64 from the arm64 preset): /usr/bin/voxcap-edge, /etc/voxcap/edge.toml
#           (a conffile), the voxcap-edge.service unit, the service user (postinst);
#   host -> voxcap (the build machine's architecture): /usr/bin/voxcap, /usr/bin/voxcap-host,
#           /usr/libexec/voxcap/voxcap-bench, the voxcap-host.service unit, the udev rule, the example rig
#           files under /usr/share/voxcap/rigs.
# `cpack` in a build tree makes the packages of the parts it has (deploy/README.md).
include_guard(GLOBAL)

set(VC_PACKAGING_DIR ${PROJECT_SOURCE_DIR}/deploy/packaging)
set(VC_SYSTEMD_UNITDIR lib/systemd/system) # /usr/lib/systemd/system under the /usr prefix
set(VC_UDEV_RULESDIR lib/udev/rules.d)

if(VC_PART_EDGE)
  install(FILES ${VC_PACKAGING_DIR}/edge.toml DESTINATION /etc/voxcap COMPONENT edge)
  install(FILES ${VC_PACKAGING_DIR}/edge.toml DESTINATION ${CMAKE_INSTALL_DATADIR}/voxcap/examples COMPONENT edge)
  install(FILES ${VC_PACKAGING_DIR}/voxcap-edge.service DESTINATION ${VC_SYSTEMD_UNITDIR} COMPONENT edge)
  install(FILES ${PROJECT_SOURCE_DIR}/edge/daemon/README.md DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/voxcap-edge
          COMPONENT edge)
endif()
if(VC_PART_HOST)
  install(FILES ${VC_PACKAGING_DIR}/voxcap-host.service DESTINATION ${VC_SYSTEMD_UNITDIR} COMPONENT host)
  install(FILES ${PROJECT_SOURCE_DIR}/hw/udev/60-voxcap.rules DESTINATION ${VC_UDEV_RULESDIR} COMPONENT host)
  file(GLOB _vc_rigs ${PROJECT_SOURCE_DIR}/hw/rigs/*.toml ${PROJECT_SOURCE_DIR}/hw/rigs/*.yaml)
  install(FILES ${_vc_rigs} DESTINATION ${CMAKE_INSTALL_DATADIR}/voxcap/rigs COMPONENT host)
  install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT host)
endif()

# The Debian architecture of what this tree builds.
if(CMAKE_CROSSCOMPILING AND CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
  set(VC_DEB_ARCH arm64)
else()
  execute_process(COMMAND dpkg --print-architecture OUTPUT_VARIABLE VC_DEB_ARCH OUTPUT_STRIP_TRAILING_WHITESPACE
                  ERROR_QUIET)
  if(NOT VC_DEB_ARCH)
    set(VC_DEB_ARCH amd64)
  endif()
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME voxcap)
set(CPACK_PACKAGE_VENDOR "voxcap")
set(CPACK_PACKAGE_CONTACT "voxcap maintainers <voxcap@localhost>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "marker-less motion capture rig")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT) # <package>_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE ${VC_DEB_ARCH})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_COMPRESSION_TYPE gzip)
# Library dependencies from the binaries (dpkg-shlibdeps reads the multiarch packages' shlibs, for the
# arm64 ones too); the service user needs adduser.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser")
set(CPACK_COMPONENTS_ALL)
if(VC_PART_EDGE)
  list(APPEND CPACK_COMPONENTS_ALL edge)
endif()
if(VC_PART_HOST)
  list(APPEND CPACK_COMPONENTS_ALL host)
endif()
set(CPACK_DEBIAN_EDGE_PACKAGE_NAME voxcap-edge)
set(CPACK_DEBIAN_EDGE_DESCRIPTION "voxcap edge node daemon\n Two cameras and a trigger input: background subtraction, partial visual\n hull carving, tracking; sends hulls and features to the voxcap host.")
set(CPACK_DEBIAN_HOST_PACKAGE_NAME voxcap)
set(CPACK_DEBIAN_HOST_DESCRIPTION "voxcap host and command line\n The host aggregator (voxcap-host), the voxcap command and its benchmarks,\n the example rig files and the udev rule for the trigger box.")
configure_file(${VC_PACKAGING_DIR}/edge/postinst ${PROJECT_BINARY_DIR}/packaging/edge/postinst COPYONLY)
configure_file(${VC_PACKAGING_DIR}/edge/prerm ${PROJECT_BINARY_DIR}/packaging/edge/prerm COPYONLY)
configure_file(${VC_PACKAGING_DIR}/host/postinst ${PROJECT_BINARY_DIR}/packaging/host/postinst COPYONLY)
configure_file(${VC_PACKAGING_DIR}/host/prerm ${PROJECT_BINARY_DIR}/packaging/host/prerm COPYONLY)
file(WRITE ${PROJECT_BINARY_DIR}/packaging/edge/conffiles "/etc/voxcap/edge.toml\n")
set(CPACK_DEBIAN_EDGE_PACKAGE_CONTROL_EXTRA
  ${PROJECT_BINARY_DIR}/packaging/edge/postinst ${PROJECT_BINARY_DIR}/packaging/edge/prerm
  ${PROJECT_BINARY_DIR}/packaging/edge/conffiles)
set(CPACK_DEBIAN_HOST_PACKAGE_CONTROL_EXTRA
  ${PROJECT_BINARY_DIR}/packaging/host/postinst ${PROJECT_BINARY_DIR}/packaging/host/prerm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
