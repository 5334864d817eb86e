#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Install tinyvo to a non-default prefix and build a project outside the tree against it
# (tools/run-tests.sh). For each kind of library (static, then shared with BUILD_SHARED_LIBS=ON):
#   1. configure with the default prefix, build lib/ + port/, `cmake --install --prefix $PREFIX`, then MOVE
#      the installed tree elsewhere: every use below goes through the moved tree (relocatable package);
#   2. no internal header is installed (linalg.h, dmath.h, arena.h, tvo_border.h) and every installed header
#      compiles alone with only the installed include folder (C99, -Wall -Wextra -Wpedantic -Werror);
#   3. the installed CMake and pkg-config files name no path of the build machine (source, build folder,
#      a library path such as /usr/lib/.../libm.so);
#   4. test/external through find_package(tinyvo COMPONENTS port) (tinyvo::tinyvo, tinyvo::port) and through
#      `pkg-config tinyvo-port`, each run (test/external/main.c: version, PNG round trip, 8 VO frames, model);
#   5. the installed programs (tvo_replay, tvo_track_pair, tvo_live) run from the moved tree (shared: through
#      their $ORIGIN-relative RPATH); shared only: SONAME libtinyvo.so.<SOVERSION> (and _port, _v4l2), the
#      programs need those names; static only: the programs need no libtinyvo*.so;
#   6. each library's symbols against the functions its installed headers declare
#      (test/external/public_functions.py; libtinyvo: tinyvo/*.h, libtinyvo_port: tinyvo/port/*.h but
#      v4l2.h, libtinyvo_v4l2: tinyvo/port/v4l2.h): every declaration carries TVO_API; shared: the
#      library exports exactly those functions (nm -D), no other function and no variable; static: the
#      archive defines every one of them.
# Usage: test/external/run.sh [static|shared ...]   (default: static shared)
# Environment: TVO_EXT_PREFIX (default /tmp/tvo-prefix: $TVO_EXT_PREFIX-<kind>, moved to ...-<kind>-moved),
# TVO_EXT_BUILD (build folders $TVO_EXT_BUILD-<kind>, default build/external), JOBS.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$ROOT"
JOBS="${JOBS:-2}"
KINDS=("$@")
[ ${#KINDS[@]} -eq 0 ] && KINDS=(static shared)
PREFIX_BASE="${TVO_EXT_PREFIX:-/tmp/tvo-prefix}"
BUILD_BASE="${TVO_EXT_BUILD:-$ROOT/build/external}"
fail() { echo "[external] FAIL: $*" >&2; exit 1; }

# Step 6 for one library: check_api LIB [HEADER ...] (paths under $P/include; none: the core's tinyvo/*.h).
# Appends what is wrong to errors, what was checked to checked.
check_api() {
  local lib="$1" d="$api/$1" unmarked lib_file name extra missing data
  shift
  python3 test/external/public_functions.py cc "$P/include" "$@" >"$d.declared" \
    || fail "could not list the functions the installed headers of lib$lib declare"
  awk '{print $1}' "$d.declared" | sort -u >"$d.public"
  [ -s "$d.public" ] || fail "no function found in the installed headers of lib$lib"
  unmarked=$(awk '$2 == "unmarked" {print $1}' "$d.declared")
  [ -z "$unmarked" ] || errors+=("declared without TVO_API in the installed headers of lib$lib: ${unmarked//$'\n'/ }")
  if [ "$shared" = ON ]; then
    lib_file=$(ls "$LIBDIR/lib$lib.so."*.*.* | head -n 1)
    name=$(basename "$lib_file")
    nm -D --defined-only "$lib_file" >"$d.dynsym" || fail "nm -D $lib_file failed"
    # functions: T (W weak, i indirect); anything else defined is data (the linker's own markers aside)
    awk 'NF == 3 && $2 ~ /^[TWi]$/ {sub(/@.*/, "", $3); print $3}' "$d.dynsym" | sort -u >"$d.exported"
    data=$(awk 'NF == 3 && $2 !~ /^[TWi]$/ && $3 !~ /^(_init|_fini|_edata|_end|__bss_start)$/ {print $3}' \
           "$d.dynsym")
    extra=$(comm -13 "$d.public" "$d.exported")
    missing=$(comm -23 "$d.public" "$d.exported")
    [ -z "$extra" ] || errors+=("$name exports functions its installed headers do not declare: ${extra//$'\n'/ }")
    [ -z "$missing" ] || errors+=("$name does not export these public functions: ${missing//$'\n'/ }")
    [ -z "$data" ] || errors+=("$name exports symbols that are not functions: ${data//$'\n'/ }")
    checked+=("$name exports the $(wc -l <"$d.public") public functions of its headers and nothing else")
  else
    lib_file="$LIBDIR/lib$lib.a"
    name=$(basename "$lib_file")
    nm --defined-only "$lib_file" | awk 'NF == 3 && $2 ~ /^[TWi]$/ {print $3}' | sort -u >"$d.defined"
    missing=$(comm -23 "$d.public" "$d.defined")
    [ -z "$missing" ] || errors+=("$name does not define these public functions: ${missing//$'\n'/ }")
    checked+=("$name defines the $(wc -l <"$d.public") public functions of its headers")
  fi
}

for kind in "${KINDS[@]}"; do
  case "$kind" in
    static) shared=OFF ;;
    shared) shared=ON ;;
    *) echo "usage: test/external/run.sh [static|shared ...]" >&2; exit 2 ;;
  esac
  B="$BUILD_BASE-$kind"
  PREFIX="$PREFIX_BASE-$kind"
  MOVED="$PREFIX-moved"
  echo "== [external] $kind: build, install to $PREFIX, move to $MOVED"
  cmake -S . -B "$B" -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_SHARED_LIBS=$shared -DTVO_WERROR=ON \
        -DTVO_BUILD_TESTS=OFF -DTVO_BUILD_BENCH=OFF -DTVO_BUILD_EXAMPLES=ON >/dev/null
  cmake --build "$B" -j"$JOBS" >/dev/null
  rm -rf "$PREFIX" "$MOVED"
  cmake --install "$B" --prefix "$PREFIX" >/dev/null
  mv "$PREFIX" "$MOVED"
  P="$MOVED"
  LIBDIR="$P/lib"
  [ -d "$LIBDIR/cmake/tinyvo" ] || fail "no $LIBDIR/cmake/tinyvo"

  # 2. headers
  for h in linalg.h dmath.h arena.h tvo_border.h; do
    found=$(find "$P" -name "$h")
    [ -z "$found" ] || fail "internal header installed: $found"
  done
  hdr_dir="$B/ext-headers"
  mkdir -p "$hdr_dir"
  n=0
  while IFS= read -r h; do
    rel="${h#"$P/include/"}"
    echo "#include \"$rel\"" > "$hdr_dir/one.c"
    echo "int tvo_external_header_check;" >> "$hdr_dir/one.c"
    cc -std=c99 -Wall -Wextra -Wpedantic -Werror -D_POSIX_C_SOURCE=200809L -I"$P/include" -c "$hdr_dir/one.c" \
       -o "$hdr_dir/one.o" 2>"$hdr_dir/one.log" || { cat "$hdr_dir/one.log" >&2; fail "$rel does not compile alone"; }
    n=$((n + 1))
  done < <(find "$P/include" -name '*.h' | sort)
  echo "[external] $n installed headers compile alone; no internal header installed"

  # 3. no build-machine paths in the package files
  if grep -rnE "$ROOT|$PREFIX|/usr/lib[^ \"]*\.(so|a)" "$LIBDIR/cmake/tinyvo" "$LIBDIR/pkgconfig"; then
    fail "the installed package files above name a path of the build machine"
  fi

  # 4a. find_package
  E="$B/ext-cmake"
  rm -rf "$E"
  cmake -S test/external -B "$E" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$P" >"$B/ext-cmake.log" \
    || { cat "$B/ext-cmake.log" >&2; fail "find_package(tinyvo) project does not configure"; }
  cmake --build "$E" >/dev/null || fail "find_package(tinyvo) project does not build"
  model=$(ls "$P/share/tinyvo/models/"*.tvonn | head -n 1)
  "$E/tvo_external" "$E/frame.png" "$model" || fail "find_package build: tvo_external failed"
  # 4b. pkg-config (from the moved tree: the prefix comes from the .pc file's folder)
  export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
  pc_static=""
  [ "$shared" = OFF ] && pc_static="--static"
  [ "$(pkg-config --modversion tinyvo-port)" = "$(pkg-config --modversion tinyvo)" ] || fail "pkg-config versions differ"
  pc_models="$(pkg-config --variable=modelsdir tinyvo)"
  [ -d "$pc_models" ] || fail "pkg-config modelsdir $pc_models is not a folder"
  # shellcheck disable=SC2046
  cc -std=c99 -Wall -Wextra -Wpedantic -Werror test/external/main.c -o "$B/ext-pkgconfig" \
     $(pkg-config --cflags tinyvo-port) $(pkg-config $pc_static --libs tinyvo-port) \
     || fail "pkg-config build failed"
  env LD_LIBRARY_PATH="$LIBDIR" "$B/ext-pkgconfig" "$B/ext-pkgconfig.png" "$(ls "$pc_models"/*.tvonn | head -n 1)" \
     || fail "pkg-config build: tvo_external failed"
  unset PKG_CONFIG_PATH

  # 5. libraries; the installed programs run from the moved tree without LD_LIBRARY_PATH
  for exe in tvo_replay tvo_track_pair tvo_live; do
    [ -x "$P/bin/$exe" ] || fail "$P/bin/$exe not installed"
    "$P/bin/$exe" --version >/dev/null || fail "installed $exe does not run from the moved tree"
  done
  if [ "$shared" = ON ]; then
    for lib in tinyvo tinyvo_port tinyvo_v4l2; do
      so=$(ls "$LIBDIR/lib$lib.so."*.*.* 2>/dev/null | head -n 1)
      [ -n "$so" ] || fail "no versioned lib$lib.so.X.Y.Z in $LIBDIR"
      soname=$(readelf -d "$so" | sed -n 's/.*(SONAME).*\[\(.*\)\]/\1/p')
      [ -n "$soname" ] || fail "$so has no SONAME"
      [ -L "$LIBDIR/$soname" ] || fail "$LIBDIR/$soname (the SONAME link) is missing"
      echo "[external] $(basename "$so"): SONAME $soname"
    done
    for exe in "$E/tvo_external" "$B/ext-pkgconfig" "$P/bin/tvo_replay"; do
      readelf -d "$exe" | grep -q "NEEDED.*\[libtinyvo\.so\.[0-9]" || fail "$exe does not need libtinyvo.so.N"
      readelf -d "$exe" | grep -q "NEEDED.*\[libtinyvo_port\.so\.[0-9]" || fail "$exe does not need libtinyvo_port.so.N"
    done
  else
    for exe in "$E/tvo_external" "$B/ext-pkgconfig"; do
      if readelf -d "$exe" | grep -q "NEEDED.*libtinyvo"; then fail "$exe needs a shared libtinyvo in a static build"; fi
    done
  fi

  # 6. the exported symbols are the public API, library by library
  api="$B/ext-api"
  rm -rf "$api"
  mkdir -p "$api"
  errors=()
  checked=()
  check_api tinyvo
  port_headers=()
  for h in "$P/include/tinyvo/port/"*.h; do
    [ "$(basename "$h")" = v4l2.h ] || port_headers+=("tinyvo/port/$(basename "$h")")
  done
  check_api tinyvo_port "${port_headers[@]}"
  if [ -f "$P/include/tinyvo/port/v4l2.h" ]; then
    check_api tinyvo_v4l2 tinyvo/port/v4l2.h
  fi
  if [ ${#errors[@]} -gt 0 ]; then
    printf '[external] FAIL: %s\n' "${errors[@]}" >&2
    exit 1
  fi
  printf '[external] %s\n' "${checked[@]}"
  echo "[external] $kind: find_package and pkg-config builds pass"
done
