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

# The config will hold token hashes and MQTT passwords: root writes it, the service's group reads it
# (0640 root:asi-gateway), nobody else. The group comes from the sysusers entry installed above; on a
# real install (no DESTDIR) as root it is created here, as a package's post-install step would.
if(EXISTS "$ENV{DESTDIR}${GW_CONFIG}")
  message(STATUS "Kept: $ENV{DESTDIR}${GW_CONFIG} (already there)")
else()
  file(INSTALL DESTINATION "${sysconfdir}/asi-gateway" TYPE FILE
       FILES "${GW_SERVICE_SOURCE_DIR}/asi-gateway.example.json" RENAME asi-gateway.json
       FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ)
  if("$ENV{DESTDIR}" STREQUAL "")
    find_program(GW_SYSUSERS systemd-sysusers)
    if(GW_SYSUSERS)
      execute_process(COMMAND "${GW_SYSUSERS}" "${prefix}/lib/sysusers.d/asi-gateway.conf"
                      RESULT_VARIABLE sysusers_rc OUTPUT_QUIET ERROR_QUIET)
    endif()
    execute_process(COMMAND chgrp asi-gateway "${GW_CONFIG}" RESULT_VARIABLE chgrp_rc ERROR_QUIET)
    if(NOT chgrp_rc EQUAL 0)
      message(STATUS "${GW_CONFIG} is 0640: run `sudo systemd-sysusers && sudo chgrp asi-gateway "
                     "${GW_CONFIG}` so that the service may read it")
    endif()
  endif()
endif()
