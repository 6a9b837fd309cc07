"""GET /: the playground page; GET /static/js/{name}: its ES modules; GET /static/{name}: its style
sheet and Plotly.

The page is plain HTML + JavaScript ES modules (no build step) in ``service/static/`` (the modules
in ``service/static/js/``, served as ``text/javascript``, which module scripts require); it calls
only the public API (``/v1/...`` and ``/openapi.json``), like any client. Plotly is a vendored ``plotly.min.js`` (``service/static/vendor/``,
whose README gives its version and license), served from here: the page needs no CDN and works in
a container without internet. The Content-Security-Policy of the page allows this origin only, so a
script or request to any other host would be blocked, not silently fetched.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException
from fastapi.responses import FileResponse

router = APIRouter(include_in_schema=False)

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
MODULES_DIR = STATIC_DIR / "js"
"""The page's ES modules (entry ``main.js``): each imports the others by relative URL."""
MEDIA_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
}
CSP = (
    "default-src 'self'; script-src 'self'; connect-src 'self'; img-src 'self' data: blob:; "
    "style-src 'self' 'unsafe-inline'; font-src 'self' data:; object-src 'none'; "
    "base-uri 'none'; frame-ancestors 'none'"
)
"""Same-origin only; Plotly sets inline styles and exports PNGs through data: and blob: URLs."""
CACHE = "no-cache"
"""Revalidate on every load (cheap: ETag / Last-Modified), so a new version is never stale."""


PLOTLY_JS = STATIC_DIR / "vendor" / "plotly.min.js"
"""plotly.js, vendored (MIT license header kept at the top of the file)."""


def _file(path: Path, headers: dict[str, str] | None = None) -> FileResponse:
    return FileResponse(
        path,
        media_type=MEDIA_TYPES[path.suffix],
        headers={"Cache-Control": CACHE, "X-Content-Type-Options": "nosniff", **(headers or {})},
    )


@router.get("/", summary="The playground page")
def index() -> FileResponse:
    return _file(STATIC_DIR / "index.html", {"Content-Security-Policy": CSP})


@router.get("/static/plotly.min.js", summary="Plotly, vendored in service/static/vendor/")
def plotly() -> FileResponse:
    return _file(PLOTLY_JS)


def _shipped(folder: Path, name: str, suffixes: tuple[str, ...]) -> FileResponse:
    """A file shipped in ``folder``, by exact name: no paths, no traversal; else 404."""
    allowed = {p.name: p for p in folder.iterdir() if p.is_file() and p.suffix in suffixes}
    if name not in allowed:
        raise HTTPException(404, "no such static file")
    return _file(allowed[name])


@router.get("/static/js/{name}", summary="The playground's ES modules")
def module(name: str) -> FileResponse:
    return _shipped(MODULES_DIR, name, (".js",))


@router.get("/static/{name}", summary="The playground's style sheet")
def static(name: str) -> FileResponse:
    return _shipped(STATIC_DIR, name, (".js", ".css"))
