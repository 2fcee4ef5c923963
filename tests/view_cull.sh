#!/usr/bin/env bash
# Modelling only what the picture needs: the N-tree leaves out triangles outside the box of the
# visible receivers and the light. Every shadow ray lies in that box, so with the exact line-space
# mode the image must not change at all, while the tree gets smaller. A view into Sponza's atrium
# from inside sees a part of the building. Unfiltered: the filter's penumbra widths come from the
# blocker each ray's walk meets first, which another tree may order differently (filter.comp).
set -u
BIN=${PN_BIN:?PN_BIN not set}
SCENE=${PN_ASSETS:-../shared/assets}/dabrovic-sponza-66k.glb
[ -f "$SCENE" ] || { echo "SKIP: $SCENE missing"; exit 77; }
T=${PN_TEST_TMP:-/tmp}/view_cull
rm -rf "$T" && mkdir -p "$T"
view=(--size 96x96 --spp 9 --filter none --camera-pos 0,2,0 --camera-target 5,2,0 --light-pos 0,12,0 --light-normal 0,-1,0 --light-size 2,2)
"$BIN" render "$SCENE" "${view[@]}" --mode exact-ls --tree 6,3 --json -o "$T/cull.exr" > "$T/cull.json" || exit 1
"$BIN" render "$SCENE" "${view[@]}" --mode exact-ls --tree 6,3 --json --no-view-cull -o "$T/all.exr" > "$T/all.json" || exit 1
"$BIN" diff "$T/all.exr" "$T/cull.exr" --fail max=0 || { echo "FAIL: view culling changed the exact image"; exit 1; }
python3 - "$T/cull.json" "$T/all.json" <<'PY'
import json, sys
c, a = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print("view cull: %d triangles left out, pools %.1f MB vs %.1f MB, build %.0f ms vs %.0f ms"
      % (c["culled_by_view"], c["pool_bytes"]["total"] / 1e6, a["pool_bytes"]["total"] / 1e6, c["build_ms"], a["build_ms"]))
assert c["culled_by_view"] > 1000 and a["culled_by_view"] == 0
assert c["pool_bytes"]["total"] < a["pool_bytes"]["total"]
PY
