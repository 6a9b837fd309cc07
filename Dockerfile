# Trajectory Service. Two stages: the builder installs the project into a virtual environment; the
# runtime image gets only that environment: no compiler, no headers, no build tools, non-root.
# Runs: python -m service --host 0.0.0.0 --port 8000 (workers from TRAJ_WORKERS, see README).

FROM python:3.11-slim AS builder

ENV PYTHONDONTWRITEBYTECODE=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    PATH=/opt/venv/bin:$PATH

WORKDIR /src
RUN python -m venv /opt/venv
COPY pyproject.toml README.md ./
COPY core ./core
COPY robots ./robots
COPY service ./service
COPY bench ./bench
# Every dependency ships a binary wheel, so nothing is compiled. The C/C++ headers and static
# libraries some wheels carry (boost, eigen, casadi, numpy) only serve to build extensions: drop them.
RUN pip install . \
    && find /opt/venv -type d -name include -prune -exec rm -rf {} + \
    && find /opt/venv -type f -name '*.a' -delete

FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PATH=/opt/venv/bin:$PATH \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    MKL_NUM_THREADS=1 \
    TRAJ_WORKERS=1

# The base image's Python headers are for building extensions; nothing is built here.
RUN rm -rf /usr/local/include \
    && groupadd --gid 10001 app \
    && useradd --uid 10001 --gid 10001 --no-create-home --shell /usr/sbin/nologin app
COPY --from=builder /opt/venv /opt/venv

WORKDIR /app
USER 10001:10001
EXPOSE 8000
HEALTHCHECK --interval=30s --timeout=3s --start-period=20s --retries=3 \
    CMD ["python", "-c", "import urllib.request,sys; sys.exit(0 if urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=2).status == 200 else 1)"]
CMD ["python", "-m", "service", "--host", "0.0.0.0", "--port", "8000"]
