"""GET /docs (Swagger UI) and GET /redoc (ReDoc): the OpenAPI pages, with their assets served by
the service itself (``service/static/vendor/``, whose README gives versions and licences), so both
work without internet, in a container or on an air-gapped network. FastAPI's own pages load them
from CDNs; ``create_app`` turns those off (``docs_url=None``, ``redoc_url=None``) and includes this
router instead. The HTML is FastAPI's (``get_swagger_ui_html``, ``get_redoc_html``) with every URL
pointing at this origin: no CDN, no Google Fonts, no remote favicon, no Swagger validator badge.
"""

from __future__ import annotations

import base64
import hashlib
import re

from fastapi import APIRouter, HTTPException
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse

from service.routes.playground import STATIC_DIR

router = APIRouter(include_in_schema=False)

VENDOR_DIR = STATIC_DIR / "vendor"
VENDOR_PREFIX = "/static/vendor/"
OPENAPI_URL = "/openapi.json"
TITLE = "Trajectory Service"
ASSETS = {
    "swagger-ui-bundle.js": "text/javascript; charset=utf-8",
    "swagger-ui.css": "text/css; charset=utf-8",
    "redoc.standalone.js": "text/javascript; charset=utf-8",
    "favicon-32x32.png": "image/png",
}
"""The vendored files the two pages load, by exact name (nothing else under /static/vendor/)."""
HEADERS = {"Cache-Control": "no-cache", "X-Content-Type-Options": "nosniff"}
CSP = (
    "default-src 'self'; script-src 'self' {inline}; connect-src 'self'; img-src 'self' data:; "
    "style-src 'self' 'unsafe-inline'; font-src 'self' data:; worker-src 'self' blob:; "
    "object-src 'none'; base-uri 'none'; frame-ancestors 'none'"
)
"""Same-origin only, like the playground's: a request to any other host is blocked, not sent
(ReDoc's footer logo from cdn.redoc.ly: blocked, and ReDoc hides it). ``{inline}``: the hash of the
page's inline script (Swagger UI's start-up call), or nothing."""


def _with_csp(page: HTMLResponse) -> HTMLResponse:
    """``page`` with ``CSP`` and ``HEADERS``, its inline scripts allowed by their SHA-256."""
    body = bytes(page.body).decode()
    inline = re.findall(r"<script>(.*?)</script>", body, flags=re.S)
    hashes = " ".join(
        "'sha256-" + base64.b64encode(hashlib.sha256(s.encode()).digest()).decode() + "'"
        for s in inline
    )
    page.headers["Content-Security-Policy"] = CSP.format(inline=hashes).replace("  ", " ")
    page.headers.update(HEADERS)
    return page


@router.get("/docs")
def swagger_ui() -> HTMLResponse:
    page = get_swagger_ui_html(
        openapi_url=OPENAPI_URL,
        title=f"{TITLE} - Swagger UI",
        swagger_js_url=VENDOR_PREFIX + "swagger-ui-bundle.js",
        swagger_css_url=VENDOR_PREFIX + "swagger-ui.css",
        swagger_favicon_url=VENDOR_PREFIX + "favicon-32x32.png",
        # validatorUrl null: no badge fetched from validator.swagger.io
        swagger_ui_parameters={"validatorUrl": None, "deepLinking": True},
    )
    return _with_csp(page)


@router.get("/redoc")
def redoc() -> HTMLResponse:
    page = get_redoc_html(
        openapi_url=OPENAPI_URL,
        title=f"{TITLE} - ReDoc",
        redoc_js_url=VENDOR_PREFIX + "redoc.standalone.js",
        redoc_favicon_url=VENDOR_PREFIX + "favicon-32x32.png",
        with_google_fonts=False,
    )
    return _with_csp(page)


@router.get(VENDOR_PREFIX + "{name}")
def vendored(name: str) -> FileResponse:
    if name not in ASSETS:
        raise HTTPException(404, "no such vendored file")
    return FileResponse(VENDOR_DIR / name, media_type=ASSETS[name], headers=HEADERS)
