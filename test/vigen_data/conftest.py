"""An HTTP server on 127.0.0.1 that serves a test-made folder, honours Range requests and injects faults on demand."""

from __future__ import annotations

import hashlib
import http.server
import threading
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from vigen.data.records import DataSet, PinnedFile


@dataclass
class Served:
    """The running server: its base URL, the folder it serves, the faults to inject and the requests it saw."""

    url: str
    folder: Path
    faults: dict[str, str] = field(default_factory=dict)  # URL path -> "cut" | "cut_once" | "wrong" | "ignore_range"
    requests: list[tuple[str, str | None]] = field(default_factory=list)  # (URL path, Range header)


def _handler(served: Served) -> type[http.server.BaseHTTPRequestHandler]:
    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args) -> None:  # keep the test output clean
            pass

        def do_GET(self) -> None:
            served.requests.append((self.path, self.headers.get("Range")))
            path = served.folder / self.path.lstrip("/")
            if not path.is_file():
                self.send_error(404)
                return
            data = path.read_bytes()
            fault = served.faults.get(self.path)
            if fault == "cut_once":
                del served.faults[self.path]
            if fault == "wrong":
                data = bytes(byte ^ 0xFF for byte in data)
            start = 0
            header = self.headers.get("Range")
            if header and fault != "ignore_range":
                start = int(header.removeprefix("bytes=").split("-")[0])
                if start >= len(data):
                    self.send_error(416)
                    return
                self.send_response(206)
                self.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
            else:
                self.send_response(200)
            self.send_header("Content-Length", str(len(data) - start))
            self.end_headers()
            body = data[start:]
            if fault in ("cut", "cut_once"):
                self.wfile.write(body[: len(body) // 2])  # then the connection closes (HTTP/1.0)
                self.wfile.flush()
                return
            self.wfile.write(body)

    return Handler


@pytest.fixture
def server(tmp_path: Path):
    """Serve ``tmp_path / "served"`` on 127.0.0.1 (port 0) from a thread."""
    folder = tmp_path / "served"
    folder.mkdir()
    served = Served("", folder)
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _handler(served))
    served.url = f"http://127.0.0.1:{httpd.server_address[1]}"
    thread = threading.Thread(target=httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
    thread.start()
    yield served
    httpd.shutdown()
    httpd.server_close()
    thread.join(timeout=5)


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Every test writes into its own cache folder, never the user's, and reads no mirror from the environment."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("VIGEN_DATA", str(cache))
    monkeypatch.delenv("VIGEN_DATA_MIRROR", raising=False)
    return cache


def git_blob_of(data: bytes) -> str:
    """The git blob id of ``data``, computed here on its own (not through vigen.data)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def make_toy_dataset(mirror_folder: Path, files: dict[str, bytes], name: str = "toy") -> DataSet:
    """Write ``files`` under ``<mirror_folder>/<name>/`` and return a record pinning them (the original URL is unroutable)."""
    for relative, data in files.items():
        path = mirror_folder / name / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return DataSet(name, "test-made files", license="CC0", source="this test",
                   files=tuple(PinnedFile(relative, git_blob_of(data), len(data)) for relative, data in files.items()),
                   url_template="http://127.0.0.1:9/unused/{path}")


@pytest.fixture
def git_blob():
    """``git_blob(data)``: the git blob id of bytes."""
    return git_blob_of


@pytest.fixture
def make_toy():
    """``make_toy(mirror_folder, {relative path: bytes}, name="toy")``: write the files under a mirror, return their record."""
    return make_toy_dataset
