# `make deb`: a Debian package of everything install.cmake installs, under /usr.
#   cd build && cpack -G DEB      → lec6_<version>_<arch>.deb

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME lec6)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
string(CONCAT CPACK_PACKAGE_DESCRIPTION
       "The lec command line (status, motion, step-data backup/restore, bus scan, frame "
       "decoding, the digital twin `lec sim`) and liblec6 for C++ programs: static libraries, "
       "headers, the CMake package (find_package(lec6)) and pkg-config files.")
set(CPACK_PACKAGE_CONTACT "lec6 maintainers <lec6@localhost>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION electronics)
# The binary's run-time libraries (dpkg-shlibdeps, which needs `file`); building against the
# static libraries also needs fmt's development files.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "libfmt-dev")
set(CPACK_STRIP_FILES OFF)
include(CPack)
