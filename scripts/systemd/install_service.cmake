# Runs at install time (from install(CODE) in CMakeLists.txt), when CMAKE_INSTALL_PREFIX is the prefix
# really installed to. Writes the unit with that prefix's paths and puts the example config in place
# unless a config is already there (an admin's edits survive a reinstall). DESTDIR is honoured by
# file(INSTALL) itself.
set(prefix "${CMAKE_INSTALL_PREFIX}")

# Like GNUInstallDirs: the system prefixes keep their config in /etc, the others under the prefix.
if(prefix STREQUAL "/" OR prefix STREQUAL "/usr")
  set(sysconfdir "/etc")
else()
  set(sysconfdir "${prefix}/etc")
endif()
foreach(kind BINDIR DATADIR)
  if(IS_ABSOLUTE "${GW_INSTALL_${kind}}")
    set(dir_${kind} "${GW_INSTALL_${kind}}")
  else()
    set(dir_${kind} "${prefix}/${GW_INSTALL_${kind}}")
  endif()
endforeach()

# The placeholders of asi-gateway.service.in.
set(GW_BINDIR "${dir_BINDIR}")
set(GW_DATADIR "${dir_DATADIR}/asi-gateway")
set(GW_CONFIG "${sysconfdir}/asi-gateway/asi-gateway.json")
configure_file("${GW_SERVICE_SOURCE_DIR}/asi-gateway.service.in" "${GW_SERVICE_STAGING_DIR}/asi-gateway.service"
               @ONLY)
# /usr/lib/systemd/system and /usr/local/lib/systemd/system are both on systemd's unit search path.
file(INSTALL DESTINATION "${prefix}/lib/systemd/system" TYPE FILE
     FILES "${GW_SERVICE_STAGING_DIR}/asi-gateway.service")

if(EXISTS "$ENV{DESTDIR}${GW_CONFIG}")
  message(STATUS "Kept: $ENV{DESTDIR}${GW_CONFIG} (already there)")
else()
  file(INSTALL DESTINATION "${sysconfdir}/asi-gateway" TYPE FILE
       FILES "${GW_SERVICE_SOURCE_DIR}/asi-gateway.example.json" RENAME asi-gateway.json)
endif()
