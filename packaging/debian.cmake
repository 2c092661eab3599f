# `cpack -G DEB` (scripts/package): one package, plexus, with the programs, libplexus, its headers
# and CMake/pkg-config files, the Python module when built, the config and the systemd units.
# Configure with CMAKE_INSTALL_PREFIX=/usr so GNUInstallDirs picks Debian's multiarch libdir.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME plexus)
set(CPACK_PACKAGE_VENDOR "Plexus maintainers")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "message broker for robot components with arbitrated ports")
set(CPACK_PACKAGE_DESCRIPTION
    "Plexus connects the ports of components through node daemons (plexusd) and a name server\n(plexus-names), with port monitors in Lua and arbitration of competing connections.\nIncludes the plexus CLI, libplexus with its headers, and the Python module.")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
# DESTDIR staging keeps CMAKE_INSTALL_PREFIX at /usr while installing, so the install-time script
# (install_prefixed_files.cmake) puts the config in /etc and the units in /lib/systemd/system.
set(CPACK_SET_DESTDIR ON)
set(CPACK_STRIP_FILES ON)

set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # plexus_VERSION_ARCH.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "Plexus maintainers <maintainers@plexus.invalid>")
set(CPACK_DEBIAN_PACKAGE_SECTION net)
# Library dependencies are computed by dpkg-shlibdeps; adduser is for postinst's system user.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser")
# Headers need nlohmann-json to compile against; the Python module and timeline tools need python3.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "nlohmann-json3-dev, python3")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${CMAKE_CURRENT_SOURCE_DIR}/debian/conffiles
    ${CMAKE_CURRENT_SOURCE_DIR}/debian/postinst
    ${CMAKE_CURRENT_SOURCE_DIR}/debian/prerm
    ${CMAKE_CURRENT_SOURCE_DIR}/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

include(CPack)
