# Installation: the `lec` binary, the static libraries, the headers, the CMake
# package (find_package(lec6 CONFIG): lec6::lec6, lec6::sim), lec6.pc and
# lec6-sim.pc for pkg-config, the man page, bash completion and the example
# systemd unit of `lec serve`.

include(CMakePackageConfigHelpers)

# `make install` and cpack package what is built; they never build themselves
# (`make deb` builds first). So the .deb test cannot relink `lec` under the
# tests that run beside it.
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)

set(LEC6_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/lec6)

install(TARGETS lec RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS lec6_modbus lec6_lec lec6_client lec6_transport lec6 lec6_sim lec6_twin lec6_simulator
        EXPORT lec6Targets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
# serve/ is `lec serve`'s, inside the binary; it is not part of the library.
# cycle/ (issue 34) is `lec cycle`'s for now: its library is not installed.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/lec6 DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        PATTERN serve EXCLUDE PATTERN cycle EXCLUDE)
install(FILES ${PROJECT_BINARY_DIR}/include/lec6/version.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lec6)

install(EXPORT lec6Targets NAMESPACE lec6:: DESTINATION ${LEC6_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lec6Config.cmake.in
                              ${PROJECT_BINARY_DIR}/lec6Config.cmake
                              INSTALL_DESTINATION ${LEC6_CMAKE_DIR})
# 0.x: a minor release may change the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lec6ConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lec6Config.cmake ${PROJECT_BINARY_DIR}/lec6ConfigVersion.cmake
        DESTINATION ${LEC6_CMAKE_DIR})

foreach(pc lec6 lec6-sim)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/${pc}.pc.in ${PROJECT_BINARY_DIR}/${pc}.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/${pc}.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endforeach()

# The man page, from `lec --help` and `lec --version` (Debian's help2man).
find_program(HELP2MAN help2man)
if(HELP2MAN)
  set(man ${PROJECT_BINARY_DIR}/lec.1.gz)
  add_custom_command(
    OUTPUT ${man}
    COMMAND ${HELP2MAN} --locale=C.UTF-8 --no-info --section=1
            "--name=drive SMC LEC6 electric-actuator controllers over RS485 (Modbus RTU)"
            --output=${PROJECT_BINARY_DIR}/lec.1 $<TARGET_FILE:lec>
    COMMAND gzip -9nf ${PROJECT_BINARY_DIR}/lec.1
    DEPENDS lec
    COMMENT "Generating the man page lec.1 with help2man"
    VERBATIM)
  add_custom_target(lec_man ALL DEPENDS ${man})
  install(FILES ${man} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
else()
  message(WARNING "help2man not found: no man page (tools/install-deps.sh installs it)")
endif()

install(FILES ${PROJECT_SOURCE_DIR}/tools/completion/lec.bash
        DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions RENAME lec)
# The Wireshark dissector (docs/sniff.md): /usr/share/lec6/wireshark/lec6.lua.
install(FILES ${PROJECT_SOURCE_DIR}/tools/wireshark/lec6.lua DESTINATION ${CMAKE_INSTALL_DATADIR}/lec6/wireshark)
# Under the prefix (/usr in the package): /usr/lib/systemd/system.
install(FILES ${PROJECT_SOURCE_DIR}/docs/lec-serve.service DESTINATION lib/systemd/system)

# /usr/share/doc/lec6: the copyright file and the changelog (gzip -9n: the same
# bytes at every build), as every Debian package has them.
set(LEC6_CHANGELOG ${PROJECT_BINARY_DIR}/changelog.gz)
add_custom_command(
  OUTPUT ${LEC6_CHANGELOG}
  COMMAND gzip -9nc ${PROJECT_SOURCE_DIR}/cmake/deb/changelog > ${LEC6_CHANGELOG}
  DEPENDS ${PROJECT_SOURCE_DIR}/cmake/deb/changelog
  COMMENT "Compressing the changelog")
add_custom_target(lec6_changelog ALL DEPENDS ${LEC6_CHANGELOG})
install(FILES ${PROJECT_SOURCE_DIR}/cmake/deb/copyright ${LEC6_CHANGELOG}
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
