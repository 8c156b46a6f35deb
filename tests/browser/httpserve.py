"""A tiny static HTTP server with byte ranges, for the browser tests (python stdlib only).

Foxglove's remote-file source reads a bag by HTTP Range requests and refuses a server whose
answer lacks ``Accept-Ranges: bytes`` (``python -m http.server`` sends none). This one maps
URL prefixes to folders (``/app/`` our page, ``/foxglove/`` the npm cache, ``/data/`` the
bags), serves one layout file at ``/layout.json`` (swappable, so a test can serve a broken
one), answers ``Range: bytes=a-b`` with 206 and ``Content-Range``, and listens on a free
port of 127.0.0.1.
"""

from __future__ import annotations

import mimetypes
import re
import sys
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import unquote, urlsplit

RANGE = re.compile(r'^bytes=(\d*)-(\d*)$')
#: Types the app needs right (a worker script, the wasm decoders) beyond mimetypes' table.
TYPES = {'.js': 'text/javascript', '.wasm': 'application/wasm',
         '.mcap': 'application/octet-stream', '.json': 'application/json'}
CHUNK = 1 << 20


def parse_range(header: str, size: int) -> tuple[int, int] | None:
    """The inclusive byte span ``(first, last)`` a single-range header asks of ``size`` bytes.

    None when the header is not one satisfiable range (the caller answers 416).
    """
    match = RANGE.match(header.strip())
    if not match or match.groups() == ('', ''):
        return None
    first, last = match.groups()
    if first == '':  # a suffix: the last N bytes
        length = int(last)
        if length == 0:
            return None
        return max(0, size - length), size - 1
    start = int(first)
    end = size - 1 if last == '' else min(int(last), size - 1)
    if start >= size or end < start:
        return None
    return start, end


class Site:
    """What the server serves: URL prefix -> folder, and the file behind ``/layout.json``."""

    def __init__(self, mounts: dict[str, Path], layout: Path, cached: str = '') -> None:
        """``cached``: the mount whose files the browser may keep (``Cache-Control``)."""
        self.mounts = {prefix.strip('/'): folder.resolve() for prefix, folder in mounts.items()}
        self.layout = layout
        self.cached = cached.strip('/')

    def resolve(self, url_path: str) -> Path | None:
        """The file a URL path names, or None (outside every mount, or no such file)."""
        path = unquote(urlsplit(url_path).path)
        if path == '/layout.json':
            return self.layout
        prefix, _, rest = path.lstrip('/').partition('/')
        folder = self.mounts.get(prefix)
        if folder is None:
            return None
        target = (folder / rest).resolve()
        if folder not in target.parents and target != folder:
            return None  # '..' out of the mount
        if target.is_dir():
            target = target / 'index.html'
        return target if target.is_file() else None


class Handler(BaseHTTPRequestHandler):
    """GET and HEAD of a :class:`Site`'s files, whole or by one byte range."""

    site: Site
    protocol_version = 'HTTP/1.1'

    def do_HEAD(self) -> None:  # noqa: N802 (the stdlib's name)
        self.answer(body=False)

    def do_GET(self) -> None:  # noqa: N802
        self.answer(body=True)

    def answer(self, body: bool) -> None:
        """Send the file, its span, or the error status."""
        path = self.site.resolve(self.path)
        if path is None:
            self.send_error(HTTPStatus.NOT_FOUND)
            return
        size = path.stat().st_size
        first, last = 0, size - 1
        status = HTTPStatus.OK
        if 'Range' in self.headers:
            span = parse_range(self.headers['Range'], size)
            if span is None:
                self.send_response(HTTPStatus.REQUESTED_RANGE_NOT_SATISFIABLE)
                self.send_header('Content-Range', f'bytes */{size}')
                self.send_header('Content-Length', '0')
                self.end_headers()
                return
            first, last = span
            status = HTTPStatus.PARTIAL_CONTENT
        kind = TYPES.get(path.suffix) or mimetypes.guess_type(path.name)[0] or \
            'application/octet-stream'
        self.send_response(status)
        self.send_header('Content-Type', kind)
        self.send_header('Accept-Ranges', 'bytes')
        self.send_header('Content-Length', str(last - first + 1))
        # The Foxglove build never changes under a version: let the browser keep it (and its
        # compiled code) between the pages of a test module; everything else afresh.
        cached = self.site.cached and self.path.startswith(f'/{self.site.cached}/')
        self.send_header('Cache-Control', 'max-age=86400, immutable' if cached else 'no-store')
        if status == HTTPStatus.PARTIAL_CONTENT:
            self.send_header('Content-Range', f'bytes {first}-{last}/{size}')
        self.end_headers()
        if not body:
            return
        try:
            with open(path, 'rb') as source:
                source.seek(first)
                left = last - first + 1
                while left > 0:
                    block = source.read(min(CHUNK, left))
                    if not block:
                        break
                    self.wfile.write(block)
                    left -= len(block)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the app opens a bag with a GET it aborts at once (it wants the headers)

    def log_message(self, format: str, *args: object) -> None:  # noqa: A002
        pass  # quiet: a page load is some 100 requests


class QuietServer(ThreadingHTTPServer):
    """A browser that closes a connection mid-request (a page closed, a reload) is no error."""

    def handle_error(self, request, client_address) -> None:
        if not isinstance(sys.exc_info()[1], ConnectionError):
            super().handle_error(request, client_address)


class Server:
    """A :class:`Site` served on 127.0.0.1 (a free port) from a daemon thread (a context
    manager)."""

    def __init__(self, site: Site) -> None:
        handler = type('SiteHandler', (Handler,), {'site': site})
        self.site = site
        self.httpd = QuietServer(('127.0.0.1', 0), handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    @property
    def url(self) -> str:
        """The base URL, ``http://127.0.0.1:PORT``."""
        return f'http://127.0.0.1:{self.httpd.server_address[1]}'

    def __enter__(self) -> Server:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(5)
