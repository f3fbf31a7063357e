#!/usr/bin/env bash
# The OpenVDB showcase of docs/formats.md: a trefoil-knot tube mesh (knot.py) turned into a
# level set by OpenVDB's vdb_tool -mesh2ls at a 2048-voxel box, rendered by isoview (the
# exact trilinear surface, read sparsely: the box would be 13 GiB dense) and by OpenVDB's
# vdb_render from the same viewpoint, then extracted by isoview. Needs libopenvdb-tools;
# writes into ${OUT:-/tmp/isoview-vdb-showcase}.
#   docs/vdb/showcase.sh [D]        D: voxels along the longest axis (default 2048)
set -euo pipefail
cd "$(dirname "$0")/../.."
D=${1:-2048}
OUT=${OUT:-/tmp/isoview-vdb-showcase}
mkdir -p "$OUT"
python3 docs/vdb/knot.py > "$OUT/knot.obj"
/usr/bin/time -f "vdb_tool -mesh2ls: %e s, peak RSS %M KiB" \
    vdb_tool -read "$OUT/knot.obj" -mesh2ls d="$D" w=3 -write "$OUT/knot.vdb" -quiet
vdb_print -l "$OUT/knot.vdb" | grep -E "active voxels|Bounding box|Dimensions"
cat > "$OUT/knot.toml" <<TOML
[image]
width = 640
height = 480
[camera]
eye = [0.0, -3.0, 9.0]
target = [0.0, -0.4, 0.0]
fov_y_deg = 40.0
[surface]
isovalue = 0.0
[field]
source = "file"
path = "knot.vdb"
TOML
# The tree is read sparsely under the default cap (the brick pool: only the bricks the
# isovalue needs are uploaded).
/usr/bin/time -f "isoview render: %e s, peak RSS %M KiB" \
    ./x render "$OUT/knot.toml" -o "$OUT/knot.exr" --png "$OUT/knot-isoview.png"
# vdb_render's -fov is horizontal: 2 atan(tan(20 deg) * 640 / 480) = 51.8 deg.
/usr/bin/time -f "vdb_render: %e s, peak RSS %M KiB" \
    vdb_render "$OUT/knot.vdb" "$OUT/knot-openvdb.png" -res 640x480 -translate 0,-3,9 \
    -lookat 0,-0.4,0 -up 0,1,0 -fov 51.8 -shader diffuse -samples 4
# extract streams windows of point layers from the tree (trilinear marching cubes).
/usr/bin/time -f "isoview extract: %e s, peak RSS %M KiB" \
    ./x extract "$OUT/knot.toml" -o "$OUT/knot.ply"
