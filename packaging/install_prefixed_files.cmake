# Runs at install time (install(SCRIPT) in CMakeLists.txt): writes the files that contain absolute
# paths using the prefix actually installed to, honouring DESTDIR (cpack) and the install manifest.
set(prefix "${CMAKE_INSTALL_PREFIX}")
# The GNU rule GNUInstallDirs applies: a /usr prefix keeps its config in /etc.
if(prefix MATCHES "^/usr/?$")
    set(sysconfdir /etc)
    set(default_unit_dir /lib/systemd/system)
else()
    set(sysconfdir "${prefix}/etc")
    set(default_unit_dir "${prefix}/lib/systemd/system")
endif()
if(NOT plexus_unit_dir)
    set(plexus_unit_dir "${default_unit_dir}")
endif()

# The names the templates use.
set(PROJECT_VERSION "${plexus_version}")
set(CMAKE_INSTALL_PREFIX "${prefix}")
set(CMAKE_INSTALL_FULL_BINDIR "${prefix}/${plexus_bindir}")
set(CMAKE_INSTALL_FULL_LIBDIR "${prefix}/${plexus_libdir}")
set(CMAKE_INSTALL_FULL_INCLUDEDIR "${prefix}/${plexus_includedir}")
set(CMAKE_INSTALL_FULL_DATADIR "${prefix}/${plexus_datadir}")
set(CMAKE_INSTALL_FULL_DOCDIR "${prefix}/${plexus_docdir}")
set(PLEXUS_FULL_CONFDIR "${sysconfdir}/plexus")

# configure_file writes into a staging directory; file(INSTALL) then adds DESTDIR and records the
# files in install_manifest.txt.
set(staging "${plexus_staging_dir}")
configure_file("${plexus_packaging_dir}/plexus.pc.in" "${staging}/plexus.pc" @ONLY)
configure_file("${plexus_packaging_dir}/systemd/plexusd.service.in" "${staging}/plexusd.service" @ONLY)
configure_file("${plexus_packaging_dir}/systemd/plexus-names.service.in" "${staging}/plexus-names.service" @ONLY)

file(INSTALL "${staging}/plexus.pc" DESTINATION "${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig")
file(INSTALL "${staging}/plexusd.service" "${staging}/plexus-names.service" DESTINATION "${plexus_unit_dir}")
file(INSTALL "${plexus_packaging_dir}/etc/plexusd.json" "${plexus_packaging_dir}/etc/plexus-names.env"
     DESTINATION "${PLEXUS_FULL_CONFDIR}")
