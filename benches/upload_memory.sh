#!/usr/bin/env bash
# Peak memory of the server under concurrent large uploads: N (default 8)
# clients each POST a 255 MiB raw body at once to the release binary with
# the default limits; prints the server's peak RSS (VmHWM) and how each
# upload was answered. `docs/BENCHMARKS.md` ("Upload memory") quotes it.
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-8}
bin=${ISOREMESH_BIN:-target/release/isoremesh}
[[ -x $bin ]] || cargo build --release --quiet
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
head -c 267386880 /dev/zero | tr '\0' '#' >"$dir/big.obj"
port=$((20000 + RANDOM % 20000))
"$bin" serve --listen "127.0.0.1:$port" --workers 1 --data-dir "$dir/data" 2>"$dir/log" &
pid=$!
for _ in $(seq 100); do curl -fs "http://127.0.0.1:$port/healthz" >/dev/null && break; sleep 0.1; done
clients=()
for i in $(seq "$n"); do
    curl -s -o "$dir/out$i" -H 'content-type: model/obj' --data-binary @"$dir/big.obj" \
        "http://127.0.0.1:$port/v1/jobs" &
    clients+=($!)
done
wait "${clients[@]}" || true
grep VmHWM "/proc/$pid/status"
kill "$pid"
wait "$pid" 2>/dev/null || true
for i in $(seq "$n"); do jq -r .type "$dir/out$i"; done | sort | uniq -c
