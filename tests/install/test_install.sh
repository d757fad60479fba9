#!/bin/sh
# The installed package: `cmake --install` into a scratch prefix, then what a user of
# the installed bbc does with it: build examples/print_cell out of tree with
# find_package(bbc) and with pkg-config (shared and static), run the README's sharded
# precompute with GNU parallel on the installed tools, read the man pages, build the
# Debian packages. Each test_<name> function is one ctest entry (install.<name>); the
# build folder is BBC_BIN, and nothing is written outside the scratch folder.
set -u
. "$BBC_SOURCE_DIR/tests/cli/lib.sh"
PREFIX="$TMP/prefix"
# The library folder of the build (CMAKE_INSTALL_LIBDIR: lib/x86_64-linux-gnu on Debian).
LIBDIR=$(sed -n 's/^CMAKE_INSTALL_LIBDIR:PATH=//p' "$BBC_BIN/CMakeCache.txt")
[ -n "$LIBDIR" ] || { echo "no CMAKE_INSTALL_LIBDIR in $BBC_BIN/CMakeCache.txt" >&2; exit 1; }

install_bbc() {
  cmake --install "$BBC_BIN" --prefix "$PREFIX" >"$TMP/install.log" 2>&1 ||
    { cat "$TMP/install.log" >&2; fail "cmake --install failed"; }
}

# A small cache written by the installed tools, for the example to read.
make_cache() {
  expect_status 0 "$PREFIX/bin/bbc-scenegen" flat-mirror -o "$TMP/mirror.gltf" --size 20
  expect_status 0 "$PREFIX/bin/bbc-precompute" "$TMP/mirror.gltf" -o "$TMP/mirror.bbc" \
    --chains R --max-level 4 --resolution 64 --no-progress
}

# The example's output names the cache and the cell, and its list is the one
# bbc-inspect dump prints for the same cell (an independent reader of the same file).
check_print_cell() {
  exe=$1
  expect_status 0 "$exe" "$TMP/mirror.bbc"
  cp "$TMP/out" "$TMP/print_cell.out"
  grep -q "^$TMP/mirror.bbc: libbbc $(sed -n 's/^project(bbc VERSION \([0-9.]*\).*/\1/p' \
    "$BBC_SOURCE_DIR/CMakeLists.txt")" "$TMP/print_cell.out" ||
    fail "$exe: unexpected first line: $(head -n 1 "$TMP/print_cell.out")"
  n=$(sed -n 's/^cell [0-9]*: \([0-9]*\) tuples$/\1/p' "$TMP/print_cell.out")
  [ -n "$n" ] && [ "$n" -gt 0 ] || fail "$exe: no non-empty cell printed: $(cat "$TMP/print_cell.out")"
  [ "$(grep -c '^  tuple ' "$TMP/print_cell.out")" -eq "$n" ] || fail "$exe: $n tuples announced"
  expect_status 2 "$exe" "$TMP/mirror.bbc" 12x
  expect_status 1 "$exe" "$TMP/missing.bbc"
}

# tools, headers, both libraries, the CMake package, bbc.pc and the man pages are
# installed; no private header is, and the headers are exactly libbbc/include/bbc.
test_files() {
  install_bbc
  for f in bin/bbc-precompute bin/bbc-render bin/bbc-inspect bin/bbc-scenegen \
    include/bbc/bbc.h $LIBDIR/libbbc.a $LIBDIR/libbbc.so $LIBDIR/cmake/bbc/bbcConfig.cmake \
    $LIBDIR/cmake/bbc/bbcConfigVersion.cmake $LIBDIR/pkgconfig/bbc.pc \
    share/man/man1/bbc-precompute.1 share/man/man1/bbc-render.1 \
    share/man/man1/bbc-inspect.1 share/man/man1/bbc-scenegen.1 share/man/man5/bbc.5; do
    [ -e "$PREFIX/$f" ] || fail "$f is not installed"
  done
  find "$PREFIX" -name '*_internal.h' | grep . && fail "a private header is installed"
  (cd "$BBC_SOURCE_DIR/libbbc/include/bbc" && ls) >"$TMP/want"
  (cd "$PREFIX/include/bbc" && ls) >"$TMP/got"
  cmp -s "$TMP/want" "$TMP/got" || fail "installed headers differ: $(diff "$TMP/want" "$TMP/got")"
  # The SONAME follows the version (libbbc.so.MAJOR, libbbc.so.0.MINOR before 1.0).
  soname=$(readelf -d "$PREFIX/$LIBDIR/libbbc.so" | sed -n 's/.*SONAME.*\[\(.*\)\]/\1/p')
  [ -e "$PREFIX/$LIBDIR/$soname" ] || fail "SONAME $soname is not installed"
  case $soname in libbbc.so.[0-9]*) ;; *) fail "SONAME $soname" ;; esac
  # The installed tools run from the prefix (they find libbbc.so relative to themselves),
  # also after the prefix is moved, and bbc.pc names the moved prefix.
  expect_status 0 "$PREFIX/bin/bbc-render" --version
  grep -q "^bbc-render .*libbbc" "$TMP/out" || fail "bbc-render --version: $(cat "$TMP/out")"
  mv "$PREFIX" "$TMP/moved"
  expect_status 0 "$TMP/moved/bin/bbc-render" --version
  PKG_CONFIG_PATH="$TMP/moved/$LIBDIR/pkgconfig" pkg-config --cflags bbc >"$TMP/cflags" ||
    fail "pkg-config bbc failed in the moved prefix"
  grep -q -- "-I$TMP/moved/$LIBDIR/pkgconfig/[./]*include\( \|$\)" "$TMP/cflags" ||
    fail "bbc.pc does not follow the moved prefix: $(cat "$TMP/cflags")"
}

# Installed to /usr (into DESTDIR, as a package is made), the tools carry no RUNPATH and
# bbc.pc says prefix=/usr, so pkg-config prints no -I or -L of its own for bbc.
test_system_prefix() {
  DESTDIR="$TMP/root" cmake --install "$BBC_BIN" --prefix /usr >"$TMP/install.log" 2>&1 ||
    { cat "$TMP/install.log" >&2; fail "cmake --install --prefix /usr failed"; }
  for tool in bbc-precompute bbc-render bbc-inspect bbc-scenegen; do
    readelf -d "$TMP/root/usr/bin/$tool" >"$TMP/dyn" || fail "readelf $tool"
    grep -q 'R.*PATH' "$TMP/dyn" && fail "$tool has a RUNPATH in /usr: $(grep 'R.*PATH' "$TMP/dyn")"
  done
  pc="$TMP/root/usr/$LIBDIR/pkgconfig/bbc.pc"
  grep -qx 'prefix=/usr' "$pc" || fail "bbc.pc in /usr: $(head -n 1 "$pc")"
  PKG_CONFIG_SYSTEM_INCLUDE_PATH=/usr/include PKG_CONFIG_SYSTEM_LIBRARY_PATH="/usr/$LIBDIR" \
    PKG_CONFIG_PATH="$TMP/root/usr/$LIBDIR/pkgconfig" pkg-config --cflags --libs bbc >"$TMP/flags" ||
    fail "pkg-config bbc failed"
  grep -q -- '-I/usr/include\( \|$\)\|-L/usr\|\.\./' "$TMP/flags" &&
    fail "pkg-config bbc in /usr names system folders: $(cat "$TMP/flags")"
  grep -q -- '-lbbc' "$TMP/flags" || fail "pkg-config bbc: $(cat "$TMP/flags")"
}

# The tools need nothing but the public headers: they compile against the installed
# include folder alone, without libbbc/src or the build tree.
test_tools_public_headers() {
  install_bbc
  for tool in bbc-precompute bbc-render bbc-inspect; do
    ${CC:-cc} -std=c11 -fsyntax-only -I"$PREFIX/include" -I"$BBC_SOURCE_DIR/cli"\
      "$BBC_SOURCE_DIR/$tool/main.c" 2>"$TMP/err" ||
      { cat "$TMP/err" >&2; fail "$tool does not build against the installed headers"; }
  done
  ${CC:-cc} -std=c11 -fsyntax-only -I"$PREFIX/include" "$BBC_SOURCE_DIR/cli/cli.c" \
    2>"$TMP/err" || { cat "$TMP/err" >&2; fail "cli.c needs more than the installed headers"; }
}

test_find_package() {
  install_bbc
  make_cache
  cmake -S "$BBC_SOURCE_DIR/examples" -B "$TMP/example" -DCMAKE_PREFIX_PATH="$PREFIX" \
    -DCMAKE_BUILD_TYPE=Release >"$TMP/cmake.log" 2>&1 ||
    { cat "$TMP/cmake.log" >&2; fail "find_package(bbc) failed"; }
  cmake --build "$TMP/example" >"$TMP/build.log" 2>&1 ||
    { cat "$TMP/build.log" >&2; fail "building against bbc::bbc failed"; }
  readelf -d "$TMP/example/print_cell" | grep -q 'NEEDED.*libbbc\.so' ||
    fail "print_cell does not link libbbc.so"
  readelf -d "$TMP/example/print_cell_static" | grep -q 'NEEDED.*libbbc\.so' &&
    fail "print_cell_static links libbbc.so"
  check_print_cell "$TMP/example/print_cell"
  mv "$TMP/print_cell.out" "$TMP/shared.out"
  check_print_cell "$TMP/example/print_cell_static"
  cmp -s "$TMP/shared.out" "$TMP/print_cell.out" || fail "shared and static outputs differ"
}

test_pkg_config() {
  install_bbc
  make_cache
  cp -r "$BBC_SOURCE_DIR/examples" "$TMP/example"
  PKG_CONFIG_PATH="$PREFIX/$LIBDIR/pkgconfig" make -C "$TMP/example" >"$TMP/make.log" 2>&1 ||
    { cat "$TMP/make.log" >&2; fail "building with pkg-config failed"; }
  readelf -d "$TMP/example/print_cell_static" | grep -q 'NEEDED.*libbbc\.so' &&
    fail "print_cell_static links libbbc.so"
  LD_LIBRARY_PATH="$PREFIX/$LIBDIR" check_print_cell "$TMP/example/print_cell"
  mv "$TMP/print_cell.out" "$TMP/shared.out"
  check_print_cell "$TMP/example/print_cell_static"
  cmp -s "$TMP/shared.out" "$TMP/print_cell.out" || fail "shared and static outputs differ"
}

# The README's GNU parallel example ("Spreading a precompute over machines"), taken
# from the README as it is written and run on the installed tools; the merge must be
# byte-identical to the unsharded cache.
test_readme_shards() {
  command -v parallel >/dev/null || fail "GNU parallel is missing (sh scripts/install-deps.sh)"
  install_bbc
  awk '/^## Spreading a precompute over machines/ { s = 1 }
       s && /^```sh$/ { c = 1; next }
       c && /^```$/ { exit }
       c { print }' "$BBC_SOURCE_DIR/README.md" >"$TMP/example.sh"
  grep -q '^parallel bbc-precompute' "$TMP/example.sh" ||
    fail "no parallel example in the README: $(cat "$TMP/example.sh")"
  mkdir "$TMP/run"
  expect_status 0 "$PREFIX/bin/bbc-scenegen" wavy-mirror -o "$TMP/run/scene.gltf" --size 200
  (cd "$TMP/run" && PATH="$PREFIX/bin:$PATH" HOME="$TMP" sh -e "$TMP/example.sh" \
    </dev/null >"$TMP/out" 2>"$TMP/err") || { cat "$TMP/err" >&2; fail "the README example failed"; }
  [ "$(ls "$TMP/run/shards" | wc -l)" -gt 1 ] || fail "no shards written"
  expect_status 0 "$PREFIX/bin/bbc-precompute" "$TMP/run/scene.gltf" -o "$TMP/full.bbc" \
    --no-progress
  cmp "$TMP/full.bbc" "$TMP/run/scene.bbc" || fail "merged shards differ from the unsharded cache"
}

# Each man page shows its tool's --help: every line of the help text appears, in order,
# in the rendered page (except the title line, the usage prefix and the subsection
# headings, which become NAME, SYNOPSIS and subsection titles).
test_man_pages() {
  install_bbc
  command -v groff >/dev/null || fail "groff is missing (sh scripts/install-deps.sh)"
  for tool in bbc-precompute bbc-render bbc-inspect bbc-scenegen; do
    "$PREFIX/bin/$tool" --help >"$TMP/help" || fail "$tool --help failed"
    [ "$(wc -l <"$TMP/help")" -gt 10 ] || fail "$tool --help is short"
    LC_ALL=C groff -man -Tascii -P-cbou "$PREFIX/share/man/man1/$tool.1" >"$TMP/page" 2>"$TMP/err" ||
      fail "$tool.1 does not render: $(cat "$TMP/err")"
    [ -s "$TMP/err" ] && fail "$tool.1: groff warns: $(cat "$TMP/err")"
    awk 'NR == FNR {
           if (FNR == 1 || /^[Uu]sage:/ || /^[^ ].*:$/ || /^ *$/) next
           sub(/^ +/, ""); sub(/ +$/, ""); want[++n] = $0; next }
         { sub(/^ +/, ""); sub(/ +$/, ""); if (k < n && $0 == want[k + 1]) k++ }
         END { if (k < n) { print "missing: " want[k + 1]; exit 1 } }' \
      "$TMP/help" "$TMP/page" >"$TMP/cmp" || fail "$tool.1 is not its --help: $(cat "$TMP/cmp")"
  done
  LC_ALL=C groff -man -Tascii -P-cbou "$PREFIX/share/man/man5/bbc.5" >"$TMP/page" 2>"$TMP/err" ||
    fail "bbc.5 does not render"
  grep -q 'R-HDR-1' "$TMP/page" || fail "bbc.5 lacks the spec's requirements"
  grep -q 'Appendix C' "$TMP/page" || fail "bbc.5 lacks the changelog"
}

# cpack -G DEB: the runtime package depends on the libraries the tools load (from
# dpkg-shlibdeps), and its tools run from the unpacked package. (`lintian` on the two
# packages, after `sh scripts/install-deps.sh --lint`, names what is left.)
test_deb() {
  command -v dpkg-deb >/dev/null || fail "dpkg-deb is missing"
  (cd "$TMP" && cpack -G DEB --config "$BBC_BIN/CPackConfig.cmake" -B "$TMP/pkg" \
    >"$TMP/cpack.log" 2>&1) || { cat "$TMP/cpack.log" >&2; fail "cpack -G DEB failed"; }
  runtime=$(ls "$TMP/pkg"/bbc_*.deb) || fail "no bbc package"
  dev=$(ls "$TMP/pkg"/libbbc-dev_*.deb) || fail "no libbbc-dev package"
  depends=$(dpkg-deb -f "$runtime" Depends)
  for p in libembree3-3 libopenexr-3-1-30 libzstd1 libtinygltf2d libgomp1 libc6; do
    echo "$depends" | grep -q "$p" || fail "bbc does not depend on $p: $depends"
  done
  # libbbc-dev: the runtime package of the same version, the -dev packages bbc.pc and
  # bbcConfig.cmake name, and the C++ library that linking libbbc.a needs.
  depends=$(dpkg-deb -f "$dev" Depends)
  for p in "bbc (= " libembree-dev libopenexr-dev libzstd-dev libtinygltf-dev zlib1g-dev \
    "libstdc++-"; do
    echo "$depends" | grep -qF "$p" || fail "libbbc-dev does not depend on $p: $depends"
  done
  dpkg-deb -c "$runtime" | grep -q '/usr/bin/bbc-render$' || fail "bbc-render not in $runtime"
  dpkg-deb -c "$runtime" | grep -q 'man1/bbc-render.1' || fail "bbc-render.1 not in $runtime"
  dpkg-deb -c "$dev" | grep -q '/usr/include/bbc/bbc.h$' || fail "bbc.h not in $dev"
  dpkg-deb -c "$runtime" "$dev" | grep -q '_internal\.h' && fail "a private header is packaged"
  # Each package has its copyright and changelog; man pages are gzipped.
  for f in bbc/copyright bbc/changelog.gz; do
    dpkg-deb -c "$runtime" | grep -q "/usr/share/doc/$f$" || fail "$f not in $runtime"
  done
  for f in libbbc-dev/copyright libbbc-dev/changelog.gz; do
    dpkg-deb -c "$dev" | grep -q "/usr/share/doc/$f$" || fail "$f not in $dev"
  done
  dpkg-deb -c "$runtime" | grep -q 'man1/bbc-render\.1\.gz$' || fail "bbc-render.1.gz not in $runtime"
  dpkg-deb -c "$runtime" | grep -q 'man5/bbc\.5\.gz$' || fail "bbc.5.gz not in $runtime"
  # Libraries in the multiarch folder, tools without RUNPATH, bbc.pc with prefix=/usr.
  dpkg-deb -c "$runtime" | grep -q "/usr/$LIBDIR/libbbc\.so\.[0-9.]*$" ||
    fail "libbbc.so.* not in /usr/$LIBDIR in $runtime"
  dpkg-deb -c "$dev" | grep -q "/usr/$LIBDIR/pkgconfig/bbc\.pc$" || fail "bbc.pc not in $dev"
  dpkg-deb -x "$runtime" "$TMP/root"
  dpkg-deb -x "$dev" "$TMP/root"
  readelf -d "$TMP/root/usr/bin/bbc-render" | grep 'R.*PATH' && fail "bbc-render has a RUNPATH"
  grep -qx 'prefix=/usr' "$TMP/root/usr/$LIBDIR/pkgconfig/bbc.pc" || fail "bbc.pc prefix"
  LD_LIBRARY_PATH="$TMP/root/usr/$LIBDIR" expect_status 0 "$TMP/root/usr/bin/bbc-render" --version
}

"test_$1"
