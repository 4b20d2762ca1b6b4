# What `cmake --install` puts beside the programs, and the Debian package CPack makes of it
# (deploy/package.sh): the manual pages, the bash completion, the Python package and, in the
# component "service" (installed by the package and by deploy/install-service.sh, not by a
# plain `cmake --install`), the systemd unit and the daemon's configuration under /etc.
include(GNUInstallDirs)

# The manual pages, made from the programs' own --help (deploy/man.sh). Not in the sanitizer
# builds, whose programs are for the tests.
if(DEMBUF_SERVICE AND NOT DEMBUF_SANITIZE AND NOT DEMBUF_FUZZ)
  set(man_dir ${PROJECT_BINARY_DIR}/man)
  add_custom_command(
    OUTPUT ${man_dir}/dembuf.1 ${man_dir}/dembufd.1
    COMMAND bash ${PROJECT_SOURCE_DIR}/deploy/man.sh $<TARGET_FILE:dembuf> $<TARGET_FILE:dembufd>
            ${man_dir} > /dev/null
    DEPENDS dembuf dembufd ${PROJECT_SOURCE_DIR}/deploy/man.sh
    COMMENT "Making the manual pages from --help")
  add_custom_target(dembuf_man ALL DEPENDS ${man_dir}/dembuf.1 ${man_dir}/dembufd.1)
  install(FILES ${man_dir}/dembuf.1 ${man_dir}/dembufd.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
endif()

# The completion, for both programs (it reads each one's --help).
set(completion ${PROJECT_SOURCE_DIR}/deploy/dembuf-completion.bash)
install(FILES ${completion} DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions
        RENAME dembuf)
if(DEMBUF_SERVICE)
  install(FILES ${completion} DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions
          RENAME dembufd)

  # The unit names the program where this install puts it, known only at install time
  # (cmake --install --prefix, or the package's /usr).
  install(CODE "
    set(unit_dir \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/lib/systemd/system\")
    set(DEMBUFD_PROGRAM \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}/dembufd\")
    file(MAKE_DIRECTORY \"\${unit_dir}\")
    configure_file(\"${PROJECT_SOURCE_DIR}/deploy/dembufd.service.in\"
                   \"\${unit_dir}/dembufd.service\" @ONLY)
    message(STATUS \"Installing: \${unit_dir}/dembufd.service\")"
    COMPONENT service EXCLUDE_FROM_ALL)
  # The configuration is the system's: /etc/dembuf, whatever the prefix (the unit names it).
  install(FILES ${PROJECT_SOURCE_DIR}/deploy/dembufd.toml DESTINATION /etc/dembuf
          COMPONENT service EXCLUDE_FROM_ALL)
endif()

# The Debian package: every component in one package, dependencies from the libraries the
# programs link (dpkg-shlibdeps) and the Python modules' packages.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME dembuf)
set(CPACK_PACKAGE_VENDOR "dembuf developers")
set(CPACK_PACKAGE_CONTACT "dembuf developers <dembuf@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
# Every component, the service's too, in the one package.
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ALL_COMPONENTS_IN_ONE)
set(CPACK_COMPONENTS_ALL Unspecified python service)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3, python3-numpy, python3-pandas, passwd")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3-grpcio, python3-protobuf, gnuplot-nox")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/deploy/debian/conffiles ${PROJECT_SOURCE_DIR}/deploy/debian/postinst
    ${PROJECT_SOURCE_DIR}/deploy/debian/prerm ${PROJECT_SOURCE_DIR}/deploy/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
