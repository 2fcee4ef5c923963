#!/usr/bin/env bash
# The library as a user gets it (engine/api): `cmake --install` into a fresh prefix, then
#  - the installed files, and the shared library's exports: the API's symbols and nothing else
#    (nm -D), every function the header declares among them;
#  - the README's C example, exactly as the README has it, built with pkg-config and with a CMake
#    project's find_package (shared and static), all three printing the same V;
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

# --- the README's example, as it stands there
awk '/<!-- api-example/ {f = 1; next} f && /^```c/ {g = 1; next} g && /^```/ {exit} g {print}' \
  "$SRC/README.md" > "$T/example.c"
[ "$(wc -l < "$T/example.c")" -gt 10 ] || fail "no C example after <!-- api-example --> in README.md"
export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
# shellcheck disable=SC2046
cc -std=c17 -Wall -Wextra -Werror "$T/example.c" $(pkg-config --cflags --libs penumbra) -o "$T/example_pc" \
  || fail "the README example does not build with pkg-config"
LD_LIBRARY_PATH="$LIBDIR" "$T/example_pc" > "$T/out_pc.txt" || fail "the README example failed"
cat "$T/out_pc.txt"
[ "$(wc -l < "$T/out_pc.txt")" -eq 4 ] || fail "the example printed $(wc -l < "$T/out_pc.txt") lines, not 4"

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
