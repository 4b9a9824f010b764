# `make deb`: a Debian package of everything install.cmake installs, under /usr.
#   cd build && cpack -G DEB      → lec6_<version>_<arch>.deb

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lec6)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
string(CONCAT CPACK_PACKAGE_DESCRIPTION
       "The lec command line (status, motion, step-data backup/restore, bus scan, frame "
       "decoding, the digital twin `lec sim`); `lec serve`, the bus owner that shares an RS485 "
       "line with PLCs and SCADA (Modbus TCP), scripts (HTTP + server-sent events), MQTT and "
       "a web dashboard (live plots, moves, step data, alarms) served from /usr/share/lec6/web; "
       "and liblec6 for C++ programs: static libraries, headers, the CMake package "
       "(find_package(lec6)) and pkg-config files.")
set(CPACK_PACKAGE_CONTACT "lec6 maintainers <lec6@localhost>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION electronics)
# The binary's run-time libraries (dpkg-shlibdeps, which needs `file`), and fmt's
# development files: lec6.pc says `Requires: fmt` and lec6Config.cmake finds fmt, so
# building against the static libraries fails without them (a Depends, not a Recommends).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "libfmt-dev")
# The tested tree's flags keep line tables (-g1); the package is stripped, as Debian's are.
set(CPACK_STRIP_FILES ON)
include(CPack)
