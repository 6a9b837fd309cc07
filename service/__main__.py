"""``python -m service --host H --port P [--workers N]`` starts the API under uvicorn.

Defaults come from the ``TRAJ_*`` environment variables (``service.settings``); a flag wins over its
variable. Before uvicorn starts, this process

- pins BLAS/OpenMP pools to one thread per worker (``OMP_NUM_THREADS`` etc.) unless already set, so
  N workers use N cores instead of N x cores threads;
- with more than one worker, points ``PROMETHEUS_MULTIPROC_DIR`` at a fresh temporary directory
  (removed on exit) so ``/metrics`` sums every worker; a directory given by the caller is used as is,
  after its stale ``*.db`` files are deleted;
- hands uvicorn a logging config with JSON lines (``TRAJ_LOG_FORMAT``) and turns off uvicorn's own
  access log, since the app writes one line per request with its request id, route and duration;
- hands uvicorn an HTTP protocol (``service.middleware.http_protocol``) that sets ``TCP_NODELAY`` on
  every connection (with several workers uvicorn leaves Nagle's algorithm on, 44 ms a keep-alive
  request), cuts off a client whose headers take longer than ``TRAJ_HEADER_TIMEOUT_S`` and answers
  malformed HTTP in problem+json;
- bounds idle keep-alive connections (``TRAJ_KEEP_ALIVE_TIMEOUT_S``) and the connections plus
  running requests of each worker (``TRAJ_MAX_CONNECTIONS``, uvicorn's ``limit_concurrency``; more
  is 503 ``overloaded``). Body and write timeouts are the app's (``service.app``).

It imports neither the app nor prometheus_client: workers must see the environment set here first.
"""

from __future__ import annotations

import argparse
import contextlib
import glob
import os
import shutil
import tempfile
from collections.abc import Iterator

import uvicorn

from service.middleware.http_protocol import PROTOCOL
from service.middleware.logging_setup import log_config
from service.settings import LOG_LEVELS, Settings, SettingsError

THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
MULTIPROC_VAR = "PROMETHEUS_MULTIPROC_DIR"


@contextlib.contextmanager
def multiprocess_metrics_dir(workers: int) -> Iterator[str | None]:
    """Set ``PROMETHEUS_MULTIPROC_DIR`` for the workers; yield it (``None``: single-process mode)."""
    given = os.environ.get(MULTIPROC_VAR)
    if given:
        os.makedirs(given, exist_ok=True)
        for stale in glob.glob(os.path.join(given, "*.db")):
            os.remove(stale)
        yield given
        return
    if workers <= 1:
        yield None
        return
    path = tempfile.mkdtemp(prefix="traj-metrics-")
    os.environ[MULTIPROC_VAR] = path
    try:
        yield path
    finally:
        os.environ.pop(MULTIPROC_VAR, None)
        shutil.rmtree(path, ignore_errors=True)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m service", description="Start Trajectory Service under uvicorn."
    )
    try:
        settings = Settings.from_env()
    except SettingsError as e:
        parser.error(str(e))
    parser.add_argument("--host", default=settings.host, help=f"bind address ({settings.host})")
    parser.add_argument(
        "--port", type=int, default=settings.port, help=f"TCP port ({settings.port})"
    )
    parser.add_argument(
        "--workers", type=int, default=settings.workers, help=f"processes ({settings.workers})"
    )
    parser.add_argument(
        "--log-level", type=str.lower, default=settings.log_level, choices=LOG_LEVELS
    )
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error("--workers must be >= 1")
    for var in THREAD_VARS:
        os.environ.setdefault(var, "1")
    with multiprocess_metrics_dir(args.workers):
        uvicorn.run(
            "service.app:create_app",
            factory=True,
            host=args.host,
            port=args.port,
            workers=args.workers,
            log_level=args.log_level,
            log_config=log_config(args.log_level, settings.log_format),
            access_log=False,
            http=PROTOCOL,  # service/middleware/http_protocol.py
            timeout_keep_alive=settings.keep_alive_timeout_s,  # type: ignore[arg-type]  # seconds, any
            limit_concurrency=settings.max_connections,
        )


if __name__ == "__main__":
    main()
