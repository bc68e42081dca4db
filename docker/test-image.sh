#!/usr/bin/env bash
# Build the image from docker/Dockerfile and run its batch entrypoint inside a container on a
# 2-row parameter table of a short block_impact case; tests/test_docker_image.py checks OUT.
#
#   docker/test-image.sh OUT
#
# With a Docker engine: `docker build`, then `docker run` with OUT mounted on /runs.
# Without one (no engine, no registry): podman/buildah with chroot isolation, from a
# debian:bookworm base made locally by mmdebstrap when it cannot be pulled. Under chroot
# isolation bind mounts are empty and `podman run` may be refused, so the table is copied into
# a buildah container, the entrypoint runs there (`buildah run`) writing to /tmp/runs, and the
# results are copied out of the container's file system.
# Writes OUT/image.json (engine, where the base came from: registry, mmdebstrap or local (found
# already), build seconds, image size) and OUT/sweep/ (the batch).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:?usage: docker/test-image.sh OUT}
IMAGE=${IMAGE:-yade-fenicsx-coupling}
BASE=docker.io/library/debian:bookworm
mkdir -p "$OUT/in"
OUT=$(cd "$OUT" && pwd)
# two short runs that differ in the coupling's relaxation
cat > "$OUT/in/params.csv" <<'EOF'
name,coupling.relaxation,time.duration,output.every
r5,5,4e-5,6
r20,20,4e-5,6
EOF
chmod -R a+rX "$OUT"

if docker info >/dev/null 2>&1; then
    engine=docker base=registry
    t0=$(date +%s)
    docker build -t "$IMAGE" -f docker/Dockerfile .
    build_s=$(( $(date +%s) - t0 ))
    size=$(docker image inspect --format '{{.Size}}' "$IMAGE")
    docker run --rm -v "$OUT:/runs" "$IMAGE" cases/block_impact.toml \
        --table /runs/in/params.csv --out /runs/sweep
else
    command -v podman >/dev/null && command -v buildah >/dev/null || {
        echo "error: no Docker engine, and podman/buildah are missing: make setup-image-build" >&2
        exit 2; }
    engine=podman base=local          # already there
    if ! podman image exists "$BASE"; then
        base=registry
        if ! timeout 120 podman pull "$BASE"; then
            base=mmdebstrap
            tmp=$(mktemp -d)
            mmdebstrap --variant=minbase bookworm "$tmp/bookworm.tar"
            podman import "$tmp/bookworm.tar" "$BASE"
            rm -rf "$tmp"
        fi
    fi
    t0=$(date +%s)
    podman build --isolation chroot -t "$IMAGE" -f docker/Dockerfile .
    build_s=$(( $(date +%s) - t0 ))
    size=$(podman image inspect --format '{{.Size}}' "$IMAGE")
    entrypoint=$(podman image inspect --format '{{range .Config.Entrypoint}}{{.}} {{end}}' "$IMAGE")
    c=$(buildah from "$IMAGE")
    trap 'buildah umount "$c" >/dev/null 2>&1 || true; buildah rm "$c" >/dev/null' EXIT
    buildah copy "$c" "$OUT/in/params.csv" /tmp/runs/in/params.csv >/dev/null
    buildah run --isolation chroot "$c" -- /usr/bin/python3 -c \
        "import cli.env as e; e.check()"
    # shellcheck disable=SC2086  # the entrypoint's words
    buildah run --isolation chroot "$c" -- $entrypoint cases/block_impact.toml \
        --table /tmp/runs/in/params.csv --out /tmp/runs/sweep
    rm -rf "$OUT/sweep"
    cp -a "$(buildah mount "$c")/tmp/runs/sweep" "$OUT/sweep"
fi
printf '{"engine": "%s", "base": "%s", "build_s": %d, "size_bytes": %d}\n' \
    "$engine" "$base" "$build_s" "$size" > "$OUT/image.json"
echo "image $IMAGE: built in ${build_s} s ($engine, base from $base), $size bytes; results in $OUT"
