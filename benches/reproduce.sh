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

# Seconds since $1 (an $EPOCHREALTIME), to the millisecond.
elapsed() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.3f\n", b - a }'; }

# Runs a command, its output discarded, and prints its wall time in seconds.
seconds() {
    local t0=$EPOCHREALTIME
    "$@" >/dev/null || return
    elapsed "$t0"
}

# The median of the numbers given, with their range: "MEDIAN (MIN–MAX)".
median() {
    python3 -c 'import statistics, sys
v = sorted(map(float, sys.argv[1:]))
print(f"{statistics.median(v):.3f} ({v[0]:.3f}–{v[-1]:.3f})")' "$@"
}

# Our whole-process seconds in the JSON file of a peers.py run (or the
# status of a run that did not succeed).
ours_seconds() {
    python3 -c 'import json, sys
r = next(r for r in json.load(open(sys.argv[1]))["runs"] if r["tool"] == "ours")
print("%.2f" % r["seconds"] if r["status"] == "ok" else r["status"])' "$1"
}

# A shape of src/shapes.rs written as an OBJ in $OUT, by the same formulas:
# `torus`, the criterion bench's 1M-triangle torus (shapes::torus(3, 1, 2000,
# 250)), or `rod`, the strip of tests/remesh_anisotropic.rs
# (shapes::open_cylinder(1, 36, 48, 1)). Prints the path.
shape_obj() {
    local path=$OUT/$1.obj
    [[ -e $path ]] || python3 -c 'import math, sys
shape, path = sys.argv[1:]
v = []
if shape == "torus":
    nu, nv, major, minor = 2000, 250, 3.0, 1.0
    for i in range(nu):
        u = math.tau * i / nu
        for j in range(nv):
            a = math.tau * j / nv
            r = major + minor * math.cos(a)
            v.append((r * math.cos(u), r * math.sin(u), minor * math.sin(a)))
    k = lambda i, j: (i % nu) * nv + j % nv
    quads = [(k(i, j), k(i + 1, j), k(i + 1, j + 1), k(i, j + 1))
             for i in range(nu) for j in range(nv)]
else:
    radius, height, segments, rows = 1.0, 36.0, 48, 1
    for i in range(rows + 1):
        z = height * i / rows
        for j in range(segments):
            a = math.tau * j / segments
            v.append((radius * math.cos(a), radius * math.sin(a), z))
    k = lambda i, j: i * segments + j % segments
    quads = [(k(i, j), k(i, j + 1), k(i + 1, j + 1), k(i + 1, j))
             for i in range(rows) for j in range(segments)]
with open(path, "w") as out:
    out.writelines("v %r %r %r\n" % p for p in v)
    out.writelines("f %d %d %d\nf %d %d %d\n" % (a + 1, b + 1, c + 1, a + 1, c + 1, d + 1)
                   for a, b, c, d in quads)' "$1" "$path"
    printf '%s\n' "$path"
}

# Edits of src/main.rs for `variant`: the system allocator instead of
# mimalloc, and transparent huge pages left as the system sets them.
NO_MIMALLOC='/^#\[global_allocator\]$/d; /^static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;$/d'
HUGE_PAGES_ON='s/^    disable_transparent_huge_pages();$/    let _ = disable_transparent_huge_pages as fn();/'

# variant NAME PROFILE EDIT...: builds the binary of PROFILE from a copy of
# the repository whose src/main.rs has the given sed edits, as
# $OUT/variants/NAME. The repository itself is not touched.
variant() {
    local name=$1 profile=$2 copy=$OUT/variants/$1.src edit
    shift 2
    rm -rf "$copy"
    mkdir -p "$copy"
    tar -c --exclude=./target --exclude=./.git . | tar -x -C "$copy"
    for edit in "$@"; do
        cp "$copy/src/main.rs" "$copy/main.rs.before"
        sed -i "$edit" "$copy/src/main.rs"
        if cmp -s "$copy/main.rs.before" "$copy/src/main.rs"; then
            echo "reproduce.sh: the edit '$edit' no longer applies to src/main.rs" >&2
            exit 1
        fi
    done
    cargo build --manifest-path "$copy/Cargo.toml" --profile "$profile" --bin isoremesh \
        --target-dir "$OUT/variants/target"
    cp "$OUT/variants/target/$profile/isoremesh" "$OUT/variants/$name"
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
  textured                     the textured table (generated shapes and the Duck, from
                               tests/attributes_transfer.rs), then the Duck with and
                               without its texture coordinates, 7 alternated runs
  adaptive [MESH...]           uniform, adaptive and uniform-at-the-adaptive-face-count
                               remeshes, measured with quality.py (default: spot,
                               bunny, fertility)
  feature-tradeoff             the scans with and without features
  option-sweep                 the nine quality meshes under eight option sets
  forced-angles MESH [OUT]     feature sectors of MESH, and with OUT (a remesh of
                               MESH) its smallest angles inside and outside them
  check-stats IN OUT           isoremesh stats against quality.py on one pair
  service [SERVE OPTIONS]      submit-to-succeeded times of igea and the bunny, 5 runs
                               each, against `isoremesh serve` (release binary) on a
                               free port; extra options go to serve (e.g.
                               --max-prepared-bytes 0); needs curl and jq
  shipped [PART...]            what the shipped binary's choices buy; PART is
                               profiles (dist against release: callgrind on camelhead,
                               the 1M torus), allocator (mimalloc against glibc) or
                               huge-pages (transparent huge pages on and off); default
                               all three; builds variants in $OUT/variants
  obj                          texture coordinates through OBJ: spot.obj's `vt`, the
                               Duck written as OBJ and read back, and the time texture
                               coordinates add
  noise-creases                smallest angles and crease-sample distances of ours and
                               gpytoolbox on igea, the bunny and camelhead
  hard-edges [PEERS.PY OPTIONS] ours with --features angle, normals and both on the
                               product files, the Duck and 2CylinderEngine
  normals [PEERS.PY OPTIONS]   ours with --normals recompute and transfer on the
                               product files, the Duck and 2CylinderEngine
  engine [PEERS.PY OPTIONS]    2CylinderEngine: every tool, the builder's repairs, the
                               welded topology, and the rod of tests/remesh_anisotropic.rs

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
hard-edges)
    # Creases from the dihedral angle, from the input's normals, and both,
    # on the glTF files (the formats that carry authored normals).
    build_release
    for fs in angle normals both; do
        echo "## features: $fs"
        python3 "$SHARED/bench/peers.py" "$MESHES/products" "$MESHES/gltf/Duck.glb" \
            "$MESHES/gltf/2CylinderEngine.glb" --tools '' \
            --ours "target/release/isoremesh $OURS_ARGS --features $fs" "$@"
    done
    ;;
normals)
    # Normals recomputed, and transferred from the input (whose hard edges
    # then become seams), on the glTF files.
    build_release
    for ns in recompute transfer; do
        echo "## normals: $ns"
        python3 "$SHARED/bench/peers.py" "$MESHES/products" "$MESHES/gltf/Duck.glb" \
            "$MESHES/gltf/2CylinderEngine.glb" --tools '' \
            --ours "target/release/isoremesh $OURS_ARGS --normals $ns" "$@"
    done
    ;;
textured)
    # The table of generated textured shapes and the Duck (the rows that
    # tests/attributes_transfer.rs prints), then the Duck with and without
    # its texture coordinates: the same geometry as a plain OBJ, 7 runs
    # each, alternated.
    cargo test --release --test attributes_transfer -- --nocapture --test-threads 1 2>/dev/null |
        grep -o '| .* |$'
    build_release
    mkdir -p "$OUT"
    duck=$MESHES/gltf/Duck.glb
    python3 -c 'import sys
from meshload import load_mesh
V, F = load_mesh(sys.argv[1])[:2]
with open(sys.argv[2], "w") as f:
    f.writelines("v %r %r %r\n" % tuple(map(float, p)) for p in V)
    f.writelines("f %d %d %d\n" % tuple(int(i) + 1 for i in t) for t in F)' "$duck" "$OUT/duck-plain.obj"
    declare -A secs=()
    for _ in 1 2 3 4 5 6 7; do
        for v in plain textured; do
            in=$OUT/duck-plain.obj
            [[ $v == textured ]] && in=$duck
            t0=$EPOCHREALTIME
            target/release/isoremesh remesh "$in" "$OUT/duck-$v.glb" --target-edge-ratio 0.0075 \
                --stats "$OUT/duck-$v.stats.json" >/dev/null
            secs[$v]+=" $(elapsed "$t0")"
        done
    done
    for v in plain textured; do
        jq -r --arg v "$v" --arg t "$(median ${secs[$v]})" '.output |
            "Duck \($v): band \(.edge_length.within_band), val6 \(.valence.regular_fraction), " +
            "valence deviation \(.valence.mean_abs_deviation), smallest angle \(.angles.min_deg)°, " +
            "Hausdorff/diag \(.distance.hausdorff_relative), whole process \($t) s"' \
            "$OUT/duck-$v.stats.json"
    done
    ;;
headline)
    build_release
    if [[ $# -eq 0 ]]; then
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
service)
    # ISOREMESH_BIN measures another build (an older commit's, for a
    # before-and-after in one sitting).
    if [[ -n ${ISOREMESH_BIN:-} ]]; then
        bin=$(abs "$ISOREMESH_BIN")
    else
        build_release
        bin=target/release/isoremesh
    fi
    mkdir -p "$OUT"
    data=$(mktemp -d)
    port=$(python3 -c 'import socket
s = socket.socket()
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1])')
    "$bin" serve --listen "127.0.0.1:$port" --data-dir "$data" "$@" 2>"$OUT/service.log" &
    server=$!
    trap 'kill "$server" 2>/dev/null || true; wait "$server" 2>/dev/null || true; rm -rf "$data"' EXIT
    base=http://127.0.0.1:$port
    for _ in {1..100}; do
        curl -sf "$base/healthz" >/dev/null && break
        if ! kill -0 "$server" 2>/dev/null; then
            echo "reproduce.sh: serve exited; see $OUT/service.log" >&2
            exit 1
        fi
        sleep 0.1
    done
    if ! curl -sf "$base/healthz" >/dev/null; then
        echo "reproduce.sh: serve does not answer on $base; see $OUT/service.log" >&2
        exit 1
    fi
    # Seconds from just before the POST until a poll, every 20 ms, sees
    # `succeeded`; the job is deleted afterwards.
    submit() {
        local t0=$EPOCHREALTIME id status
        id=$(curl -sSf -F "mesh=@$1" -F 'params={"target_edge_ratio":0.0075}' \
            "$base/v1/jobs" | jq -er .id) || return
        while :; do
            status=$(curl -sSf "$base/v1/jobs/$id" | jq -er .status) || return
            case $status in
            succeeded) break ;;
            failed | cancelled)
                echo "reproduce.sh: job $id $status" >&2
                return 1
                ;;
            esac
            sleep 0.02
        done
        elapsed "$t0"
        curl -sSf -X DELETE "$base/v1/jobs/$id" >/dev/null
    }
    meshes=(igea.ply stanford-bunny.obj)
    declare -A waits=()
    # Interleaved: igea, bunny, igea, bunny, ...
    for _ in 1 2 3 4 5; do
        for m in "${meshes[@]}"; do
            t=$(submit "$MESHES/$m")
            waits[$m]+=" $t"
        done
    done
    for m in "${meshes[@]}"; do
        echo "$m: submit to succeeded $(median ${waits[$m]}) s (median, min–max of 5)"
    done
    ;;
shipped)
    [[ $# -gt 0 ]] || set -- profiles allocator huge-pages
    build_release
    build_dist
    mkdir -p "$OUT/variants"
    cp target/release/isoremesh "$OUT/variants/release"
    cp target/dist/isoremesh "$OUT/variants/dist"
    ratio=(--target-edge-ratio 0.0075)
    torus=$(shape_obj torus)
    for part in "$@"; do
        echo "## $part"
        case $part in
        profiles)
            for b in release dist; do
                n=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null "$OUT/variants/$b" \
                    remesh "$MESHES/camelhead.off" "$OUT/camelhead.$b.obj" "${ratio[@]}" 2>&1 |
                    sed -n 's/.*Collected : //p')
                echo "camelhead, $b: $n instructions"
            done
            # The 1M torus through the CLI with --stats, the two builds alternating.
            for _ in 1 2 3; do
                for b in dist release; do
                    t=$(seconds "$OUT/variants/$b" remesh "$torus" "$OUT/torus.$b.obj" \
                        --stats "$OUT/torus.$b.stats.json")
                    echo "1M torus, $b: $t s"
                done
            done
            ;;
        allocator)
            # Both allocators with huge pages left as the system sets them.
            variant release-glibc release "$NO_MIMALLOC" "$HUGE_PAGES_ON"
            variant dist-glibc dist "$NO_MIMALLOC" "$HUGE_PAGES_ON"
            variant dist-huge-pages dist "$HUGE_PAGES_ON"
            builds=(release-glibc dist-glibc dist-huge-pages)
            declare -A camel=()
            for _ in 1 2 3 4 5 6 7 8; do
                for b in "${builds[@]}"; do
                    t=$(seconds "$OUT/variants/$b" remesh "$MESHES/camelhead.off" \
                        "$OUT/camelhead.$b.obj" "${ratio[@]}")
                    camel[$b]+=" $t"
                done
            done
            for b in "${builds[@]}"; do
                echo "camelhead, $b: $(median ${camel[$b]}) s (median, min–max of 8)"
            done
            for b in dist-glibc dist-huge-pages; do
                for m in spot.obj stanford-bunny.obj; do
                    /usr/bin/time -f "$m, $b: %R minor page faults, peak RSS %M KB" \
                        "$OUT/variants/$b" remesh "$MESHES/$m" "$OUT/alloc.obj" "${ratio[@]}"
                done
                /usr/bin/time -f "1M torus, $b: %R minor page faults, peak RSS %M KB" \
                    "$OUT/variants/$b" remesh "$torus" "$OUT/alloc.obj"
            done
            ;;
        huge-pages)
            variant dist-huge-pages dist "$HUGE_PAGES_ON"
            # Right after a CGAL run, as in `peers`: peers.py runs and scores
            # CGAL, then runs ours, whose peak RSS /usr/bin/time writes.
            for m in spot.obj fertility.off cube.obj stanford-bunny.obj; do
                for b in dist-huge-pages dist; do
                    for _ in 1 2 3; do
                        python3 "$SHARED/bench/peers.py" "$MESHES/$m" --tools cgal \
                            --ours "/usr/bin/time -f %M -o $OUT/rss $OUT/variants/$b $OURS_ARGS" \
                            --json "$OUT/huge-pages.json" >/dev/null 2>&1
                        t=$(ours_seconds "$OUT/huge-pages.json")
                        echo "$m, $b: $t s, peak RSS $(tail -n 1 "$OUT/rss") KB"
                    done
                done
            done
            # Warm memory: the runs follow each other.
            for b in dist-huge-pages dist; do
                for _ in 1 2 3; do
                    t=$(seconds "$OUT/variants/$b" remesh "$MESHES/igea.ply" "$OUT/igea.$b.obj" \
                        "${ratio[@]}")
                    echo "igea, $b: $t s"
                done
                for _ in 1 2 3; do
                    t=$(seconds "$OUT/variants/$b" remesh "$torus" "$OUT/torus.$b.obj")
                    echo "1M torus, $b: $t s"
                done
            done
            ;;
        *)
            usage >&2
            exit 2
            ;;
        esac
    done
    ;;
obj)
    build_release
    bin=target/release/isoremesh
    dir=$OUT/obj
    mkdir -p "$dir"
    ratio=(--target-edge-ratio 0.0075)
    "$bin" remesh "$MESHES/spot.obj" "$dir/spot.glb" "${ratio[@]}" \
        --stats "$dir/spot.stats.json" >/dev/null
    jq -r '.attributes.texcoords[0] as $t |
        "spot.obj: \(.output.faces) faces, \($t.charts_out) charts, " +
        "\($t.seam_within_1pct_l) of the seam length within 0.01·L, " +
        "\($t.uv_flipped) UV-flipped, \($t.uv_degenerate) UV-degenerate triangles"' \
        "$dir/spot.stats.json"
    # The Duck written as OBJ, .mtl and PNG (no iterations: the repaired
    # input as it is), then read back and remeshed.
    "$bin" remesh "$MESHES/gltf/Duck.glb" "$dir/Duck.obj" --iterations 0
    "$bin" remesh "$dir/Duck.obj" "$dir/Duck.glb" "${ratio[@]}" \
        --stats "$dir/Duck.stats.json" >/dev/null
    jq -r '.attributes.texcoords[0].color_error | "Duck through OBJ: colour error mean \(.mean), " +
        "p99 \(.p99) (R, G, B, A; 8-bit units)"' "$dir/Duck.stats.json"
    # Whole process with and without texture coordinates: each file against
    # a copy with its positions and faces only (the welded OBJ of meshload.py).
    for m in gltf/Duck.glb spot.obj; do
        in=$MESHES/$m
        plain=$dir/$(basename "${in%.*}").plain.obj
        python3 -c 'import sys
from meshload import load_mesh, write_obj
write_obj(sys.argv[2], *load_mesh(sys.argv[1]))' "$in" "$plain"
        with='' without=''
        for _ in 1 2 3 4 5 6 7; do
            with+=" $(seconds "$bin" remesh "$in" "$dir/o.glb" "${ratio[@]}")"
            without+=" $(seconds "$bin" remesh "$plain" "$dir/o.glb" "${ratio[@]}")"
        done
        echo "$m: with texture coordinates $(median $with) s, positions only $(median $without) s"
    done
    ;;
noise-creases)
    build_dist
    mkdir -p "$OUT"
    python3 "$SHARED/bench/peers.py" "$MESHES/igea.ply" "$MESHES/stanford-bunny.obj" \
        "$MESHES/camelhead.off" --tools gpytoolbox \
        --ours "target/dist/isoremesh $OURS_ARGS" --json "$OUT/noise-creases.json" >/dev/null
    python3 -c 'import json, sys
for r in json.load(open(sys.argv[1]))["runs"]:
    q = r.get("quality")
    if q:
        print("%s, %s: smallest angle %.1f°, largest crease-sample distance %.2f·L" % (
            r["mesh"], r["tool"], q["angles"]["min_deg"], q["features"]["max_over_L"]))' \
        "$OUT/noise-creases.json"
    ;;
engine)
    build_dist
    mkdir -p "$OUT"
    bin=target/dist/isoremesh
    engine=$MESHES/gltf/2CylinderEngine.glb
    python3 "$SHARED/bench/peers.py" "$engine" --tools pymeshlab,meshlib,gpytoolbox,cgal \
        --ours "$bin $OURS_ARGS" --json "$OUT/engine.json" "$@"
    echo "repairs: $("$bin" stats --json "$engine" | jq -c .repairs)"
    "$bin" remesh "$engine" "$OUT/engine.obj" --target-edge-length "$(bench_length "$engine")" \
        --stats "$OUT/engine.stats.json" >/dev/null
    jq -r '"welded (the statistics): input χ \(.input.euler_characteristic), " +
        "\(.input.boundary_loops) loops; output χ \(.output.euler_characteristic), " +
        "\(.output.boundary_loops) loops, \(.output.vertices) vertices"' "$OUT/engine.stats.json"
    rod=$(shape_obj rod)
    "$bin" remesh "$rod" "$OUT/rod.out.obj" --target-edge-length 1 --refine-curved false \
        --stats "$OUT/rod.stats.json" >/dev/null
    jq -r '.output | "rod: \(.faces) faces, \(.angles.below_30_fraction) of them below 30°, " +
        "smallest angle \(.angles.min_deg)°, " +
        "\(.edge_length.within_band) of the edges in the band"' \
        "$OUT/rod.stats.json"
    ;;
help | -h | --help)
    usage
    ;;
*)
    usage >&2
    exit 2
    ;;
esac
