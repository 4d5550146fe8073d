#!/usr/bin/env bash
# Runs the benchmarks behind the figures in docs/BENCHMARKS.md.
#
#   benches/reproduce.sh <name> [arguments]
#
# The shared bench scripts and meshes are read from $SHARED (default: the
# `shared` folder beside the repository). Output meshes and statistics files
# go to $OUT (default /tmp/isoremesh-bench). Run `benches/reproduce.sh help`
# for the list of names.
set -euo pipefail

SHARED=${SHARED:-$(dirname "$0")/../../shared}
case ${1:-help} in
help | -h | --help) ;;
*)
    if [[ ! -d $SHARED/bench || ! -d $SHARED/meshes ]]; then
        echo "reproduce.sh: no shared bench and meshes in $SHARED; set SHARED" >&2
        exit 1
    fi
    SHARED=$(cd "$SHARED" && pwd)
    ;;
esac
MESHES=$SHARED/meshes
CALLER=$PWD
# A path given relative to the directory the script was called from.
abs() { if [[ $1 == /* ]]; then printf '%s\n' "$1"; else printf '%s\n' "$CALLER/$1"; fi; }
OUT=$(abs "${OUT:-/tmp/isoremesh-bench}")

cd "$(dirname "$0")/.."
# The repository's Python scripts import the shared bench's modules.
export PYTHONPATH=$SHARED/bench${PYTHONPATH:+:$PYTHONPATH}
export ISOREMESH_SHARED_BENCH=$SHARED/bench

# The eleven shared meshes of the peers run (the sub-folders `more/` and
# `products/` are not part of it).
SHARED_MESHES=(
    "$MESHES/camelhead.off" "$MESHES/cube.obj" "$MESHES/fandisk.obj"
    "$MESHES/fertility.off" "$MESHES/igea.ply" "$MESHES/spot.obj"
    "$MESHES/stanford-bunny.obj" "$MESHES/gltf"
)
OURS_ARGS='remesh {in} {out} --target-edge-length {L} --iterations {iters} --feature-angle {angle}'

build_dist() { cargo build --profile dist --bin isoremesh; }
build_release() { cargo build --release --bin isoremesh; }

# A mesh given by path, or by its path inside $SHARED/meshes.
mesh_path() {
    if [[ -e $(abs "$1") ]]; then
        abs "$1"
    else
        printf '%s\n' "$MESHES/$1"
    fi
}

# The bench's target length: 0.75 % of the welded input's bounding-box diagonal.
bench_length() {
    python3 -c 'import sys
from meshload import bbox_diag, load_mesh
print(repr(0.0075 * bbox_diag(load_mesh(sys.argv[1])[0])))' "$1"
}

usage() {
    cat <<'EOF'
usage: benches/reproduce.sh <name> [arguments]

  peers [PEERS.PY OPTIONS]     ours (dist binary) and pymeshlab, MeshLib, gpytoolbox
                               and CGAL on the eleven shared meshes, in one run;
                               extra options go to peers.py (e.g. --keep DIR, --json FILE)
  products [PEERS.PY OPTIONS]  ours (release binary) alone on the product assets
  headline [MESH...]           remesh at L = 0.75 % of the diagonal to GLB with --stats
                               (release binary) and print the headline block; default:
                               the meshes listed in BENCHMARKS.md
  textured                     the same on gltf/Duck.glb; the statistics, with their
                               `attributes` section, are in $OUT/Duck.stats.json
  adaptive [MESH...]           uniform, adaptive and uniform-at-the-adaptive-face-count
                               remeshes, measured with quality.py (default: spot,
                               bunny, fertility)
  feature-tradeoff             the scans with and without features
  option-sweep                 the nine quality meshes under eight option sets
  forced-angles MESH [OUT]     feature sectors of MESH, and with OUT (a remesh of
                               MESH) its smallest angles inside and outside them
  check-stats IN OUT           isoremesh stats against quality.py on one pair

MESH is a path, or a path inside $SHARED/meshes (e.g. gltf/Duck.glb).
EOF
}

cmd=${1:-help}
shift || true

case $cmd in
peers)
    build_dist
    python3 "$SHARED/bench/peers.py" "${SHARED_MESHES[@]}" \
        --tools pymeshlab,meshlib,gpytoolbox,cgal \
        --ours "target/dist/isoremesh $OURS_ARGS" "$@"
    ;;
products)
    build_release
    python3 "$SHARED/bench/peers.py" "$MESHES/products" --tools '' \
        --ours "target/release/isoremesh $OURS_ARGS" "$@"
    ;;
headline | textured)
    build_release
    if [[ $cmd == textured ]]; then
        set -- gltf/Duck.glb
    elif [[ $# -eq 0 ]]; then
        set -- more/beetle.obj more/horse_quad.obj more/truck.obj more/beast.obj \
            more/ogre.obj spot.obj gltf/Duck.glb stanford-bunny.obj igea.ply
    fi
    mkdir -p "$OUT"
    for m in "$@"; do
        in=$(mesh_path "$m")
        stem=$(basename "${in%.*}")
        echo "## $m"
        target/release/isoremesh remesh "$in" "$OUT/$stem.glb" \
            --target-edge-ratio 0.0075 --stats "$OUT/$stem.stats.json"
    done
    ;;
adaptive)
    build_dist
    [[ $# -gt 0 ]] || set -- spot.obj stanford-bunny.obj fertility.off
    mkdir -p "$OUT"
    bin=target/dist/isoremesh
    # Faces and Hausdorff distance (per mille of the diagonal) from quality.py's JSON.
    measure() {
        python3 "$SHARED/bench/quality.py" "$1" "$2" --L "$3" |
            python3 -c 'import json, sys
q = json.load(sys.stdin)
print(q["topology_out"]["F"], round(1000 * q["fidelity"]["hausdorff"], 2))'
    }
    for m in "$@"; do
        in=$(mesh_path "$m")
        stem=$(basename "${in%.*}")
        L=$(bench_length "$in")
        "$bin" remesh "$in" "$OUT/$stem.uniform.obj" --target-edge-length "$L" \
            --iterations 10 --feature-angle 45 --refine-curved false
        "$bin" remesh "$in" "$OUT/$stem.adaptive.obj" --adaptive --tolerance-ratio 0.001 \
            --iterations 10 --feature-angle 45
        r=$(measure "$in" "$OUT/$stem.uniform.obj" "$L")
        read -r uf uh <<<"$r"
        r=$(measure "$in" "$OUT/$stem.adaptive.obj" "$L")
        read -r af ah <<<"$r"
        "$bin" remesh "$in" "$OUT/$stem.count.obj" --target-faces "$af" \
            --iterations 10 --feature-angle 45 --refine-curved false
        r=$(measure "$in" "$OUT/$stem.count.obj" "$L")
        read -r cf ch <<<"$r"
        echo "$m: uniform $uf faces, H $uh; adaptive $af faces, H $ah;" \
            "uniform at the adaptive count $cf faces, H $ch (H in per mille of the diagonal)"
    done
    ;;
feature-tradeoff)
    build_dist
    python3 benches/feature_tradeoff.py target/dist/isoremesh "$MESHES"
    ;;
option-sweep)
    build_dist
    python3 benches/option_sweep.py target/dist/isoremesh "$MESHES"
    ;;
forced-angles)
    [[ $# -ge 1 ]] || { usage >&2; exit 2; }
    in=$(mesh_path "$1")
    if [[ $# -ge 2 ]]; then
        python3 benches/forced_angles.py "$in" --output "$(abs "$2")"
    else
        python3 benches/forced_angles.py "$in"
    fi
    ;;
check-stats)
    [[ $# -eq 2 ]] || { usage >&2; exit 2; }
    build_release
    # check_stats.py runs quality.py from ../shared/bench beside the
    # repository, whatever $SHARED says.
    python3 benches/check_stats.py --bin target/release/isoremesh \
        --pair "$(mesh_path "$1")" "$(abs "$2")"
    ;;
help | -h | --help)
    usage
    ;;
*)
    usage >&2
    exit 2
    ;;
esac
