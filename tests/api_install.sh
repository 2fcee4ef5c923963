#!/usr/bin/env bash
# The library as a user gets it (engine/api): `cmake --install` into a fresh prefix, then
#  - the installed files, and the shared library's exports: the API's symbols and nothing else
#    (nm -D), every function the header declares among them;
#  - the README's C example and the commands after it, exactly as the README has them (its own
#    install into ~/.local, with HOME a new folder; nothing else set: the program must find the
#    library by the run path pkg-config gives), printing exactly the output the README shows; the
#    example built with a CMake project's find_package (shared and static) too, printing the same;
#  - the installed penumbra command (the library's messages name `penumbra info`);
#  - that V against render's for the same points (render --gbuffer over an EXR of them), which
#    traces them as pixels: equal to the 9 decimals both print;
#  - the Python module from the build tree and from the prefix, printing the same V.
set -euo pipefail
SRC=$(cd "$(dirname "$0")/.." && pwd)
BIN=${PN_BIN:?PN_BIN: the penumbra binary (ctest sets it)}
BUILD=$(dirname "$BIN")
T=$(mktemp -d "${PN_TEST_TMP:-/tmp}/api_install.XXXXXX")
trap 'rm -rf "$T"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

PREFIX="$T/prefix"
cmake --install "$BUILD" --prefix "$PREFIX" >/dev/null || fail "cmake --install"
LIB=$(find "$PREFIX" -name libpenumbra.so.0 | head -1)
[ -n "$LIB" ] || fail "no libpenumbra.so.0 under the prefix"
LIBDIR=$(dirname "$LIB")
for f in "$PREFIX/include/penumbra.h" "$LIBDIR/libpenumbra.so" "$LIBDIR/libpenumbra.a" "$LIBDIR/pkgconfig/penumbra.pc" \
         "$LIBDIR/cmake/penumbra/penumbraConfig.cmake" "$LIBDIR/cmake/penumbra/penumbraConfigVersion.cmake" \
         "$PREFIX/lib/python3/dist-packages/penumbra/__init__.py"; do
  [ -e "$f" ] || fail "not installed: ${f#$PREFIX/}"
done
readelf -d "$LIB" | grep -q 'SONAME.*libpenumbra.so.0' || fail "soname is not libpenumbra.so.0"

# --- exports: defined dynamic symbols are penumbra_* (and the version node) only
nm -D --defined-only "$LIB" | awk '{print $3}' | sed 's/@.*//' | sort -u > "$T/exports"
others=$(grep -v -e '^penumbra_' -e '^PENUMBRA_0$' "$T/exports" || true)
[ -z "$others" ] || fail "libpenumbra.so exports more than the API: $(echo $others | head -c 400)"
grep -o 'penumbra_[a-z_]*(' "$SRC/engine/api/penumbra.h" | tr -d '(' | sort -u > "$T/declared"
missing=$(comm -23 "$T/declared" "$T/exports")
[ -z "$missing" ] || fail "declared in penumbra.h, not exported: $missing"
echo "exports: $(wc -l < "$T/exports") symbols, all the API's"

[ -x "$PREFIX/bin/penumbra" ] || fail "not installed: bin/penumbra"
"$PREFIX/bin/penumbra" info > "$T/info.txt" 2>&1 || fail "the installed penumbra info: $(tail -n 3 "$T/info.txt")"
"$PREFIX/bin/penumbra" --help 2>&1 | grep -q render || fail "the installed penumbra --help does not list render"

# --- the README's example and its commands, as they stand there, in a new HOME
block() { # the fenced block after the README's line matching $1
  awk -v m="$1" 'index($0, m) {f = 1; next} f && /^```/ && !g {g = 1; next} g && /^```/ {exit} g {print}' "$SRC/README.md"
}
block "<!-- api-example" > "$T/example.c"
block "<!-- api-commands" > "$T/commands.sh"
block "<!-- api-output" > "$T/expected.txt"
[ "$(wc -l < "$T/example.c")" -gt 10 ] || fail "no C example after <!-- api-example --> in README.md"
grep -q "cmake --install build" "$T/commands.sh" || fail "no install command after <!-- api-commands --> in README.md"
[ "$(wc -l < "$T/expected.txt")" -eq 4 ] || fail "README.md shows $(wc -l < "$T/expected.txt") lines of output, not 4"
# Where the README's reader is: the repository's folder, with build/ and example.c in it.
mkdir -p "$T/reader/home"
ln -s "$BUILD" "$T/reader/build"
cp "$T/example.c" "$T/reader/example.c"
cp "$T/commands.sh" "$T/reader/commands.sh"
# Nothing from this environment but Mesa's shader cache folder (as bundle_check: the new HOME's
# empty cache would only make the run compile its pipelines again).
cache=${MESA_SHADER_CACHE_DIR:-${XDG_CACHE_HOME:-${HOME:-/nonexistent}/.cache}}
(cd "$T/reader" && env -i HOME="$T/reader/home" PATH=/usr/bin:/bin MESA_SHADER_CACHE_DIR="$cache" \
  bash -euo pipefail commands.sh) > "$T/out_readme.txt" 2> "$T/readme.err" ||
  { cat "$T/readme.err"; fail "the README's commands failed"; }
grep -v '^-- ' "$T/out_readme.txt" > "$T/out_pc.txt" || true # cmake --install's lines, if any
cat "$T/out_pc.txt"
diff "$T/expected.txt" "$T/out_pc.txt" || fail "the README's example printed other than the README shows"
readelf -d "$T/reader/example" | grep -qE "\(RUNPATH\)|\(RPATH\)" || fail "the README's program has no run path"
# The example is clean C17 under strict warnings, with the flags pkg-config gives.
export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
# shellcheck disable=SC2046
cc -std=c17 -Wall -Wextra -Wpedantic -Werror "$T/example.c" $(pkg-config --cflags --libs penumbra) -o "$T/example_pc" \
  || fail "the README example does not build with -std=c17 -Wall -Wextra -Wpedantic -Werror"

mkdir -p "$T/consumer"
cp "$T/example.c" "$T/consumer/"
cat > "$T/consumer/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.16)
project(consumer C)
find_package(penumbra 0.1 REQUIRED)
add_executable(example_shared example.c)
target_link_libraries(example_shared PRIVATE penumbra::penumbra)
add_executable(example_static example.c)
target_link_libraries(example_static PRIVATE penumbra::penumbra_static)
CMAKE
cmake -S "$T/consumer" -B "$T/consumer/build" -DCMAKE_PREFIX_PATH="$PREFIX" >/dev/null || fail "find_package(penumbra)"
cmake --build "$T/consumer/build" >/dev/null || fail "the find_package consumer does not build"
"$T/consumer/build/example_shared" > "$T/out_shared.txt" || fail "example_shared failed"
"$T/consumer/build/example_static" > "$T/out_static.txt" || fail "example_static failed"
cmp -s "$T/out_pc.txt" "$T/out_shared.txt" || fail "find_package (shared) printed other V"
cmp -s "$T/out_pc.txt" "$T/out_static.txt" || fail "find_package (static) printed other V"
ldd "$T/consumer/build/example_static" | grep -q libpenumbra && fail "example_static links libpenumbra.so"

# --- render's V for the same points: an EXR whose pixels are them (normal +Y, as the example's)
args=()
while read -r line; do
  xyz=$(echo "$line" | sed -E 's/^V\(([^)]*)\) = .*/\1/; s/ //g')
  args+=(--pattern "constant:color=$xyz,1,0,1,0" 1x1 7)
done < "$T/out_pc.txt"
oiiotool "${args[@]}" --mosaic 4x1 --chnames P.X,P.Y,P.Z,A,N.X,N.Y,N.Z -d float -o "$T/points.exr" \
  || fail "oiiotool: the points' EXR"
"$BIN" render builtin:default --no-ground --gbuffer "$T/points.exr" --filter none --spp 64 --seed 1 \
  -o "$T/render.exr" >/dev/null || fail "render --gbuffer"
oiiotool "$T/render.exr" --ch shadow.V -o "$T/v.exr" || fail "oiiotool: shadow.V"
oiiotool --dumpdata "$T/v.exr" | awk '/Pixel/ {print $NF}' > "$T/v_render.txt"
sed -E 's/.* = //' "$T/out_pc.txt" > "$T/v_api.txt"
paste "$T/v_api.txt" "$T/v_render.txt"
cmp -s "$T/v_api.txt" "$T/v_render.txt" || fail "the example's V differs from render's for the same points"
grep -qv -e '^0.000000000$' -e '^1.000000000$' "$T/v_api.txt" || fail "no point in penumbra: nothing to compare"

# --- Python: Debian's python3 (numpy from python3-numpy), from the build tree and from the prefix
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3
for where in "$BUILD/python" "$PREFIX/lib/python3/dist-packages"; do
  PYTHONPATH="$where" "$PY" "$SRC/tests/api_python.py" > "$T/out_py.txt" || fail "python from $where"
  cmp -s "$T/out_pc.txt" "$T/out_py.txt" || { diff "$T/out_pc.txt" "$T/out_py.txt"; fail "python from $where printed other V"; }
done
(cd "$T" && PYTHONPATH="$PREFIX/lib/python3/dist-packages" "$PY" -c "import penumbra") || fail "import penumbra"
echo "PASS"
