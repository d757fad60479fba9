# Install rules, the CMake package, bbc.pc and the Debian package (cpack -G DEB).
#   cmake --install build --prefix P
# installs the tools to P/bin, the public headers to P/include/bbc, libbbc.so and
# libbbc.a to P/LIBDIR (lib/x86_64-linux-gnu on Debian amd64), bbcConfig.cmake to
# P/LIBDIR/cmake/bbc, bbc.pc to P/LIBDIR/pkgconfig and the man pages to P/share/man.
# Installed anywhere but /usr, the tree is relocatable (RUNPATH $ORIGIN/../LIBDIR, bbc.pc
# and bbcConfig.cmake name their prefix relative to themselves); installed to /usr (the
# Debian package), the tools carry no RUNPATH and bbc.pc says prefix=/usr, so
# pkg-config drops its system -I and -L. Private headers (libbbc/src/*/*_internal.h) are never
# installed. Components: "runtime" (tools, libbbc.so.*, man pages) and "development"
# (headers, libbbc.so, libbbc.a, CMake package, bbc.pc).
include(CMakePackageConfigHelpers)

set(BBC_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/bbc)

install(TARGETS bbc-precompute bbc-render bbc-inspect bbc-scenegen
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
# Installed to /usr, libbbc.so is where the dynamic linker looks by default: no RUNPATH
# (Debian policy). Decided at install time, so one build folder serves both.
install(CODE "set(bbc_bindir \"${CMAKE_INSTALL_BINDIR}\")" COMPONENT runtime)
install(CODE [[
  if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
    foreach(tool bbc-precompute bbc-render bbc-inspect bbc-scenegen)
      file(RPATH_REMOVE FILE "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${bbc_bindir}/${tool}")
    endforeach()
  endif()
]] COMPONENT runtime)
install(TARGETS bbc_shared EXPORT bbcTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime
    NAMELINK_COMPONENT development)
install(TARGETS bbc EXPORT bbcTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT development)
install(DIRECTORY libbbc/include/bbc DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  COMPONENT development FILES_MATCHING PATTERN "*.h")
install(EXPORT bbcTargets NAMESPACE bbc:: DESTINATION ${BBC_CMAKE_DIR}
  COMPONENT development)

configure_package_config_file(cmake/bbcConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/bbcConfig.cmake INSTALL_DESTINATION ${BBC_CMAKE_DIR})
# Before 1.0 a minor version may break the API, so only the same minor version matches.
if(PROJECT_VERSION_MAJOR EQUAL 0)
  set(bbc_compatibility SameMinorVersion)
else()
  set(bbc_compatibility SameMajorVersion)
endif()
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/bbcConfigVersion.cmake
  COMPATIBILITY ${bbc_compatibility})
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/bbcConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/bbcConfigVersion.cmake
  DESTINATION ${BBC_CMAKE_DIR} COMPONENT development)

# bbc.pc: installed to /usr it says prefix=/usr (pkg-config then leaves out -I/usr/include
# and -L/usr/lib/<triplet>, its system folders); anywhere else it names its prefix
# relative to its own folder (${pcfiledir}/../../..), so the tree may be moved.
file(RELATIVE_PATH BBC_PC_PREFIX /p/${CMAKE_INSTALL_LIBDIR}/pkgconfig /p)
string(REGEX REPLACE "/$" "" BBC_PC_PREFIX "${BBC_PC_PREFIX}")
set(BBC_PC_PREFIX "\${pcfiledir}/${BBC_PC_PREFIX}")
configure_file(cmake/bbc.pc.in ${CMAKE_CURRENT_BINARY_DIR}/pc/relocatable/bbc.pc @ONLY)
set(BBC_PC_PREFIX /usr)
configure_file(cmake/bbc.pc.in ${CMAKE_CURRENT_BINARY_DIR}/pc/usr/bbc.pc @ONLY)
install(CODE "set(bbc_pc_dir \"${CMAKE_CURRENT_BINARY_DIR}/pc\")
  set(bbc_pc_dest \"${CMAKE_INSTALL_LIBDIR}/pkgconfig\")" COMPONENT development)
install(CODE [[
  if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
    set(bbc_pc "${bbc_pc_dir}/usr/bbc.pc")
  else()
    set(bbc_pc "${bbc_pc_dir}/relocatable/bbc.pc")
  endif()
  file(INSTALL DESTINATION "${CMAKE_INSTALL_PREFIX}/${bbc_pc_dest}" TYPE FILE FILES "${bbc_pc}")
]] COMPONENT development)

# cpack -G DEB (in the build folder) writes two packages: bbc (the tools, the shared
# library and the man pages; its dependencies come from dpkg-shlibdeps) and libbbc-dev
# (what building against libbbc needs, with the -dev packages bbc.pc and
# bbcConfig.cmake refer to, and the C++ library: libbbc.a holds C++ code).
set(CPACK_PACKAGE_NAME bbc)
set(CPACK_PACKAGE_VENDOR "bbc")
set(CPACK_PACKAGE_CONTACT "bbc maintainers <bbc@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Bernstein bounds for caustics (Fan et al. 2025)")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
# Install with CMAKE_INSTALL_PREFIX=/usr into DESTDIR, so the install-time choices above
# (no RUNPATH, prefix=/usr in bbc.pc) are made for the package.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime development)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION graphics)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME bbc)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
set(CPACK_STRIP_FILES ON)
# shlibs for packages linking libbbc; ldconfig runs through the trigger, not postinst.
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/debian/triggers "activate-noawait ldconfig\n")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA ${CMAKE_CURRENT_BINARY_DIR}/debian/triggers)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${CMAKE_CURRENT_BINARY_DIR}/libbbc)
set(CPACK_COMPONENT_RUNTIME_DESCRIPTION
  "bbc renders caustics from point, spot and directional lights without bias,
by bounding them into a persistent .bbc cache. This package holds
bbc-precompute, bbc-render, bbc-inspect, bbc-scenegen, the shared library
libbbc and the man pages.")
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_NAME libbbc-dev)
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_SECTION libdevel)
# The C++ library of the compiler that built libbbc.a (the virtual libstdc++-dev may be
# satisfied by another GCC's, which the default gcc does not find).
string(REGEX MATCH "^[0-9]+" bbc_cxx_major "${CMAKE_CXX_COMPILER_VERSION}")
set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_DEPENDS
  "bbc (= ${PROJECT_VERSION}), libembree-dev, libopenexr-dev, libzstd-dev, libtinygltf-dev, zlib1g-dev, libstdc++-${bbc_cxx_major}-dev | libstdc++-dev, libgomp1")
set(CPACK_COMPONENT_DEVELOPMENT_DESCRIPTION
  "What building against libbbc needs: the public headers of libbbc, its
static library, the CMake package (find_package(bbc) giving bbc::bbc and
bbc::bbc_static) and bbc.pc for pkg-config.")
# Installed to /usr, each package's /usr/share/doc/<package> holds copyright and
# changelog.gz (Debian policy 12.5, 12.7; a native package's changelog) and the man pages
# are gzipped; gzip -n: no name or time stamp inside.
string(TIMESTAMP BBC_DEB_DATE "%a, %d %b %Y %H:%M:%S +0000" UTC)
find_program(BBC_GZIP gzip)
foreach(pkg bbc libbbc-dev)
  set(BBC_DEB_PACKAGE ${pkg})
  configure_file(cmake/debian/changelog.in ${CMAKE_CURRENT_BINARY_DIR}/debian/${pkg}/changelog @ONLY)
  configure_file(cmake/debian/copyright ${CMAKE_CURRENT_BINARY_DIR}/debian/${pkg}/copyright COPYONLY)
  if(BBC_GZIP)
    execute_process(COMMAND ${BBC_GZIP} -n -9 -f changelog
      WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}/debian/${pkg})
  endif()
endforeach()
install(CODE "set(bbc_deb_doc \"${CMAKE_CURRENT_BINARY_DIR}/debian\")
  set(bbc_datarootdir \"${CMAKE_INSTALL_DATAROOTDIR}\")
  set(bbc_mandir \"${CMAKE_INSTALL_MANDIR}\")
  set(bbc_gzip \"${BBC_GZIP}\")" COMPONENT runtime)
install(CODE [[
  if(CMAKE_INSTALL_PREFIX STREQUAL "/usr" AND bbc_gzip)
    file(GLOB bbc_pages "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${bbc_mandir}/man1/bbc-*.1"
      "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/${bbc_mandir}/man5/bbc.5")
    foreach(page ${bbc_pages})
      execute_process(COMMAND ${bbc_gzip} -n -9 -f ${page} COMMAND_ERROR_IS_FATAL ANY)
    endforeach()
  endif()
]] COMPONENT runtime)
install(CODE "set(bbc_deb_doc \"${CMAKE_CURRENT_BINARY_DIR}/debian\")
  set(bbc_datarootdir \"${CMAKE_INSTALL_DATAROOTDIR}\")" COMPONENT development)
foreach(component runtime development)
  if(component STREQUAL runtime)
    set(pkg bbc)
  else()
    set(pkg libbbc-dev)
  endif()
  install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    file(GLOB bbc_docs \"\${bbc_deb_doc}/${pkg}/*\")
    file(INSTALL DESTINATION \"\${CMAKE_INSTALL_PREFIX}/\${bbc_datarootdir}/doc/${pkg}\"
      TYPE FILE FILES \${bbc_docs})
  endif()" COMPONENT ${component})
endforeach()
include(CPack)
