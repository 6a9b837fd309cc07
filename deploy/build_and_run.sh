#!/usr/bin/env bash
# Build the container image, run it, check it through the public HTTP API, stop it.
#
#   bash deploy/build_and_run.sh
#
# 1. podman, runc and mmdebstrap (Debian packages) are installed when missing (root, or sudo -n).
# 2. The base: BASE_IMAGE if set; else python:3.11-slim when Docker Hub answers; else a stand-in
#    built from Debian packages (mmdebstrap bookworm minbase + python3, imported into podman,
#    deploy/standin-base/Containerfile on top), reused by later runs while its recipe is unchanged.
# 3. `podman build` of the project's Dockerfile, tagged trajectory-service:<version of pyproject>,
#    the image deploy/compose.yaml and deploy/k8s/ name. Build time and image size are printed.
# 4. The container starts (its own network namespace, port 8000 published on a free loopback port),
#    the script runs the image's own HEALTHCHECK until it passes, checks that every process in the
#    container runs as uid 10001 and that every module of core/, robots/ and service/ imports, then
#    deploy/smoke_check.py sends a joint plan, a Cartesian plan on the UR5 and a
#    bounded_deviation_nlp plan and checks the answers. The container is removed on exit.
#
# Environment: IMAGE (tag), BASE_IMAGE, KEEP_IMAGE=1 (default; 0 removes the image at the end),
# KEEP_BUILD_CACHE=1 (keep the builder stage's images, so a rebuild reuses its pip install layer),
# HOST_PORT (default: a free port), PODMAN_STORAGE_DRIVER (default vfs), TIMING_FILE (append
# "build_seconds=... image_bytes=..." lines there). Exit status 0 only when every check passed.
set -euo pipefail

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
VERSION="$(sed -n 's/^version = "\(.*\)"$/\1/p' pyproject.toml | head -n 1)"
IMAGE="${IMAGE:-trajectory-service:${VERSION}}"
# The stand-in base: Debian bookworm minbase + Python 3.11 (python3-venv brings the pip wheel that
# `python -m venv` installs), without documentation, manual pages and translations, as
# debian:bookworm-slim (under python:3.11-slim) leaves them out. Its tag hashes this recipe and
# deploy/standin-base/Containerfile, so a changed recipe builds a new base.
MMDEBSTRAP_ARGS=(--variant=minbase --include=python3,python3-venv,ca-certificates
    --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-include=/usr/share/doc/*/copyright'
    --dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/locale/*'
    --dpkgopt='path-exclude=/usr/share/info/*' bookworm)
RECIPE="$( (printf '%s\n' "${MMDEBSTRAP_ARGS[@]}"; cat deploy/standin-base/Containerfile) | sha256sum | cut -c1-12)"
STANDIN="localhost/trajectory-standin-base:bookworm-${RECIPE}"
MINBASE="localhost/trajectory-base-minbase:bookworm-${RECIPE}"
NAME="trajectory-smoke-$$"
WORK="$(mktemp -d)"
log() { printf '== %s\n' "$*"; }

# ---- 1. tools
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo -n"
missing=()
for tool in podman runc mmdebstrap; do command -v "$tool" >/dev/null 2>&1 || missing+=("$tool"); done
if [ "${#missing[@]}" -gt 0 ]; then
    log "installing ${missing[*]} (Debian packages)"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -q
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -q podman runc mmdebstrap
fi

# podman on these machines: vfs storage, runc, no default ulimits (the sandbox refuses to raise them).
if [ -z "${CONTAINERS_CONF:-}" ]; then
    printf '[containers]\ndefault_ulimits = []\n' >"$WORK/containers.conf"
    export CONTAINERS_CONF="$WORK/containers.conf"
fi
PODMAN=(podman --storage-driver "${PODMAN_STORAGE_DRIVER:-vfs}" --runtime runc)

cleanup() {
    status=$?
    if "${PODMAN[@]}" container exists "$NAME" 2>/dev/null; then
        if [ "$status" -ne 0 ]; then
            log "container log (last 40 lines)"
            "${PODMAN[@]}" logs "$NAME" 2>&1 | tail -n 40 || true
        fi
        "${PODMAN[@]}" rm -f -t 5 "$NAME" >/dev/null 2>&1 || true
    fi
    if [ "${KEEP_IMAGE:-1}" = "0" ]; then "${PODMAN[@]}" rmi -f "$IMAGE" >/dev/null 2>&1 || true; fi
    rm -rf "$WORK"
    exit "$status"
}
trap cleanup EXIT

# ---- 2. the base image
if [ -z "${BASE_IMAGE:-}" ]; then
    if timeout 60 "${PODMAN[@]}" pull -q docker.io/library/python:3.11-slim >/dev/null 2>&1; then
        BASE_IMAGE="docker.io/library/python:3.11-slim"
    else
        BASE_IMAGE="$STANDIN"
        if ! "${PODMAN[@]}" image exists "$STANDIN"; then
            log "Docker Hub unreachable: building the stand-in base $STANDIN from Debian packages"
            mmdebstrap "${MMDEBSTRAP_ARGS[@]}" "$WORK/base.tar"
            "${PODMAN[@]}" import "$WORK/base.tar" "$MINBASE" >/dev/null
            rm -f "$WORK/base.tar"
            mkdir -p "$WORK/standin"
            cp deploy/standin-base/Containerfile "$WORK/standin/"
            cp /etc/ssl/certs/ca-certificates.crt "$WORK/standin/"
            "${PODMAN[@]}" build --format docker --network host --build-arg "FROM_IMAGE=$MINBASE" \
                -t "$STANDIN" "$WORK/standin"
        fi
    fi
fi
log "base image: $BASE_IMAGE"

# ---- 3. build
log "building $IMAGE"
previous=$("${PODMAN[@]}" image inspect --format '{{.Id}}' "$IMAGE" 2>/dev/null || true)
start=$(date +%s)
"${PODMAN[@]}" build --format docker --network host --build-arg "BASE_IMAGE=$BASE_IMAGE" \
    -t "$IMAGE" -f Dockerfile .
build_seconds=$(($(date +%s) - start))
if [ "${KEEP_BUILD_CACHE:-0}" != "1" ]; then  # vfs stores every layer whole: drop the builder stage
    "${PODMAN[@]}" image prune -f --filter label=org.trajectory-service.stage=builder >/dev/null || true
fi
current=$("${PODMAN[@]}" image inspect --format '{{.Id}}' "$IMAGE")
if [ -n "$previous" ] && [ "$previous" != "$current" ]; then  # the image this tag named before
    "${PODMAN[@]}" rmi "$previous" >/dev/null 2>&1 || true
fi
image_bytes=$("${PODMAN[@]}" image inspect --format '{{.Size}}' "$IMAGE")
log "built in ${build_seconds} s; image size $((image_bytes / 1000000)) MB (${image_bytes} bytes)"
if [ -n "${TIMING_FILE:-}" ]; then
    echo "build_seconds=${build_seconds} image_bytes=${image_bytes} base=${BASE_IMAGE}" >>"$TIMING_FILE"
fi
health=$("${PODMAN[@]}" image inspect --format '{{json .Config.Healthcheck}}' "$IMAGE")
case "$health" in
*/health*) ;;
*) echo "the image has no HEALTHCHECK on /health: $health" >&2; exit 1 ;;
esac

# ---- 4. run and check
HOST_PORT="${HOST_PORT:-$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}"
log "starting $NAME on 127.0.0.1:$HOST_PORT"
"${PODMAN[@]}" run -d --name "$NAME" -p "127.0.0.1:${HOST_PORT}:8000" -e TRAJ_WORKERS=2 \
    --read-only --tmpfs /tmp --security-opt no-new-privileges "$IMAGE" >/dev/null

log "waiting for the image's HEALTHCHECK"
run_start=$(date +%s)
deadline=$(($(date +%s) + 120))
until "${PODMAN[@]}" healthcheck run "$NAME" >/dev/null 2>&1; do
    state=$("${PODMAN[@]}" inspect --format '{{.State.Status}}' "$NAME")
    if [ "$state" != "running" ] || [ "$(date +%s)" -ge "$deadline" ]; then
        echo "the container did not become healthy (state: $state)" >&2
        exit 1
    fi
    sleep 1
done
log "healthy after $(($(date +%s) - run_start)) s"

log "every process runs as the image's non-root user"
"${PODMAN[@]}" exec "$NAME" python -c '
import os, sys
uids = {}
for pid in filter(str.isdigit, os.listdir("/proc")):
    try:
        status = open(f"/proc/{pid}/status").read()
    except OSError:
        continue
    fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
    uids[pid] = (fields["Name"].strip(), fields["Uid"].split())
print(uids)
bad = {pid: u for pid, u in uids.items() if set(u[1]) != {"10001"}}
sys.exit(1 if bad or not uids or os.getuid() != 10001 else 0)
'

log "every module of the service imports inside the image"
"${PODMAN[@]}" exec "$NAME" python -c '
import importlib, pkgutil
names = []
for package in ("core", "robots", "service"):
    module = importlib.import_module(package)
    names.append(package)
    for info in pkgutil.walk_packages(module.__path__, package + "."):
        importlib.import_module(info.name)
        names.append(info.name)
print(len(names), "modules imported")
'

log "plans through the public API"
python3 deploy/smoke_check.py "http://127.0.0.1:${HOST_PORT}"
log "OK: $IMAGE built in ${build_seconds} s, $((image_bytes / 1000000)) MB, healthy, plans checked"
