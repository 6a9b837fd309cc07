# Trajectory Service. Two stages: the builder installs the project into a virtual environment; the
# runtime image gets only that environment: no compiler, no headers, no build tools, non-root.
# Runs: python -m service --host 0.0.0.0 --port 8000 (workers from TRAJ_WORKERS, see README).
# BASE_IMAGE: any Debian-based image with python3 (+ venv) as `python`; deploy/build_and_run.sh
# passes a stand-in built from Debian packages where Docker Hub is not reachable.
ARG BASE_IMAGE=python:3.11-slim

FROM ${BASE_IMAGE} AS builder
# deploy/build_and_run.sh removes the builder images this label marks once the image is built.
LABEL org.trajectory-service.stage=builder

ENV PYTHONDONTWRITEBYTECODE=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PATH=/opt/venv/bin:$PATH

WORKDIR /src
RUN python -m venv /opt/venv
COPY pyproject.toml README.md ./
COPY deploy/slim_venv.py deploy/exclusive_requirements.py /usr/local/lib/
COPY core ./core
COPY robots ./robots
COPY service ./service
# Every dependency ships a binary wheel, so nothing is compiled. Then the environment is cut to what
# runs: pip, setuptools and wheel leave it; C/C++ headers, static libraries and CMake/pkg-config
# files (they only serve to build extensions) go; identical copies of a shared library in one
# directory (wheels store libfoo.so, libfoo.so.3 and libfoo.so.3.7 as three files) become symlinks.
# EAIK requires urchin (its URDF loader, eaik.IK_URDF) and urchin's mesh and graphics stack
# (trimesh, pyribbit, pyglet, PyOpenGL, pillow, imageio, lxml, networkx ...); the service calls
# eaik.pybindings only, from the joint axes, so that stack (about 93 MB) never runs: every
# distribution only urchin brings leaves (computed from the installed metadata, not a hand list).
# hadolint ignore=SC2046
RUN pip install . \
    && pip uninstall -y $(python /usr/local/lib/exclusive_requirements.py urchin) \
    && pip uninstall -y pip setuptools wheel \
    && python /usr/local/lib/slim_venv.py /opt/venv

FROM ${BASE_IMAGE}

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PATH=/opt/venv/bin:$PATH \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    MKL_NUM_THREADS=1 \
    TRAJ_WORKERS=1

# libgomp1: the OpenMP runtime that pinocchio's wheel links against (slim images lack it).
# apt's package lists and caches go in the same layer (80 MB where the base does not clean them).
# The base image's Python headers are for building extensions; nothing is built here.
# hadolint ignore=DL3008
RUN apt-get update \
    && apt-get install -y --no-install-recommends libgomp1 \
    && apt-get clean \
    && rm -rf /var/lib/apt/lists/* /var/cache/apt/*.bin /usr/local/include \
    && groupadd --gid 10001 app \
    && useradd --uid 10001 --gid 10001 --no-create-home --shell /usr/sbin/nologin app
COPY --from=builder /opt/venv /opt/venv

WORKDIR /app
USER 10001:10001
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=3s --start-period=20s --retries=3 \
    CMD ["python", "-c", "import urllib.request,sys; sys.exit(0 if urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=2).status == 200 else 1)"]
CMD ["python", "-m", "service", "--host", "0.0.0.0", "--port", "8000"]
