"""An HTTP server on 127.0.0.1 that serves a test-made folder, honours Range requests and injects faults on demand; made-up
records (pinned files, a DAVIS-like archive with its pin injected) for the data set tests."""

from __future__ import annotations

import dataclasses
import hashlib
import http.server
import threading
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from vigen.datasets import DATASETS, DataSet, PinnedFile


@dataclass
class Served:
    """The running server: its base URL, the folder it serves, the faults to inject and the requests it saw."""

    url: str
    folder: Path
    faults: dict[str, str] = field(default_factory=dict)  # URL path -> "cut" | "cut_once" | "wrong" | "ignore_range" | "slow"
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
            if fault == "slow":  # in 8 pieces, 25 ms apart: a second fetch starts while the first is writing
                for piece in range(8):
                    self.wfile.write(body[piece * len(body) // 8:(piece + 1) * len(body) // 8])
                    self.wfile.flush()
                    time.sleep(0.025)
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
    """The git blob id of ``data``, computed here on its own (not through vigen.datasets)."""
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


DAVIS_ZIP = "DAVIS-2017-trainval-480p.zip"
DAVIS_LAYOUT = {
    "DAVIS/ImageSets/2017/train.txt": b"bear\ncamel\n",
    "DAVIS/ImageSets/2017/val.txt": b"dog\n",
    "DAVIS/JPEGImages/480p/bear/00000.jpg": b"\xff\xd8bear0",
    "DAVIS/JPEGImages/480p/bear/00001.jpg": b"\xff\xd8bear1",
    "DAVIS/JPEGImages/480p/camel/00000.jpg": b"\xff\xd8camel0",
    "DAVIS/JPEGImages/480p/dog/00000.jpg": b"\xff\xd8dog0",
    "DAVIS/Annotations/480p/dog/00000.png": b"\x89PNGdog0",
    "DAVIS/README.md": b"synthetic DAVIS for tests\n",
}
"""A made-up archive in DAVIS 2017's layout (two train videos, one val video)."""


def write_zip(path: Path, members: dict[str, bytes]) -> bytes:
    """Write a zip of ``members`` at ``path`` and return its bytes."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return path.read_bytes()


def davis_pinned_to(archive: bytes) -> DataSet:
    """davis2017's record with its archive pin replaced by ``archive``'s sha256 and size (computed here, on its own)."""
    davis = DATASETS["davis2017"]
    return dataclasses.replace(davis, archive=dataclasses.replace(
        davis.archive, sha256=hashlib.sha256(archive).hexdigest(), size=len(archive), pinned_by="this test"))


@pytest.fixture
def served_davis(server, monkeypatch):
    """``served_davis(members=DAVIS_LAYOUT, pin=True)``: serve a made-up DAVIS zip; with ``pin``, davis2017's record pins
    it (the test's own pin, injected), else the record keeps the real pin (TensorFlow Datasets')."""
    def serve(members: dict[str, bytes] = DAVIS_LAYOUT, pin: bool = True) -> bytes:
        archive = write_zip(server.folder / "davis2017" / DAVIS_ZIP, members)
        if pin:
            monkeypatch.setitem(DATASETS, "davis2017", davis_pinned_to(archive))
        return archive

    return serve


@pytest.fixture
def davis_layout() -> dict[str, bytes]:
    """:data:`DAVIS_LAYOUT`: a made-up archive's members in DAVIS 2017's layout."""
    return dict(DAVIS_LAYOUT)
