"""What vigen.datasets keeps of its own beside pooch, measured: import cost, hashing, transfer speed, resuming, messages.

vigen.datasets fetches through :func:`pooch.retrieve` (temporary file, sha256 check, move into
place) and :class:`pooch.Unzip`, and keeps its own code where pooch lacks a feature or measures
worse. This script measures each such place in one run, against a server on 127.0.0.1 that
honours ``Range`` requests and can cut a transfer halfway:

* import: ``import vigen.datasets`` (what every env build pays: the levels call ``locate``) and
  ``import pooch`` / ``import filelock``, each in a fresh interpreter (median of ``--repeats``);
* hashing a ``--size`` MB file: vigen's ``sha256_file`` (1 MiB reads) and ``pooch.file_hash``
  (64 KiB reads); the git blob id (DMC-GB's pins), which pooch cannot compute;
* a whole transfer of that file: ``pooch.retrieve`` with pooch's ``HTTPDownloader`` (requests; its
  default 1 KiB chunks, and 1 MiB chunks) and with vigen's ``ResumingDownloader`` (urllib, 1 MiB
  reads), all checking the sha256;
* a transfer cut at half its bytes, then run again: the bytes the second run transfers;
* the messages of a missing file (HTTP 404) and of a file with another sha256: pooch's, and
  ``vigen.datasets.fetch``'s (which fetches through pooch and names the fix).

Reproduce (about a minute on 2 CPU cores; run nothing else meanwhile):

    python benchmarks/datasets_fetch.py
    python benchmarks/datasets_fetch.py --size 256 --repeats 5
"""

from __future__ import annotations

import argparse
import hashlib
import http.server
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pooch

from vigen.datasets import DataSet, PinnedFile, fetch
from vigen.datasets.fetch import ResumingDownloader
from vigen.datasets.verify import git_blob_id, sha256_file


def serve(folder: Path, cut: set[str], sent: list[int]) -> str:
    """Serve ``folder`` on 127.0.0.1 (Range honoured); a path in ``cut`` is cut at half its bytes once. Returns the URL."""

    class Handler(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args) -> None:
            pass

        def do_GET(self) -> None:
            path = folder / self.path.lstrip("/")
            if not path.is_file():
                self.send_error(404, "File not found")
                return
            size = path.stat().st_size
            start = int(self.headers["Range"].removeprefix("bytes=").split("-")[0]) if self.headers.get("Range") else 0
            self.send_response(206 if start else 200)
            if start:
                self.send_header("Content-Range", f"bytes {start}-{size - 1}/{size}")
            self.send_header("Content-Length", str(size - start))
            self.end_headers()
            stop = start + (size - start) // 2 if self.path in cut else size
            cut.discard(self.path)
            with open(path, "rb") as file:
                file.seek(start)
                while start < stop:
                    chunk = file.read(min(1 << 20, stop - start))
                    self.wfile.write(chunk)
                    start += len(chunk)
                    sent[0] += len(chunk)

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return f"http://127.0.0.1:{server.server_address[1]}"


def import_seconds(module: str, repeats: int) -> float:
    code = f"import time; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)"
    return statistics.median(float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                                  check=True).stdout) for _ in range(repeats))


def timed(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def first_line(error: BaseException) -> str:
    return f"{type(error).__name__}: {str(error).splitlines()[0][:300]}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=128, help="MB of the file hashed and transferred")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    pooch.get_logger().setLevel("WARNING")
    work = Path(tempfile.mkdtemp(prefix="vigen-bench-"))
    served = work / "served"
    served.mkdir()
    data = os.urandom(args.size << 20)
    (served / "file.bin").write_bytes(data)
    sha256 = hashlib.sha256(data).hexdigest()
    cut: set[str] = set()
    sent = [0]
    url = serve(served, cut, sent)

    print(f"import (median of {args.repeats} fresh interpreters):")
    for module in ("vigen", "vigen.datasets", "pooch", "filelock"):
        print(f"  import {module:<15} {import_seconds(module, args.repeats) * 1e3:7.1f} ms")

    print(f"hashing {args.size} MB (median of {args.repeats}):")
    path = served / "file.bin"
    for name, function in (("vigen sha256_file (1 MiB reads)", lambda: sha256_file(path)),
                           ("pooch.file_hash sha256 (64 KiB)", lambda: pooch.file_hash(str(path))),
                           ("vigen git_blob_id", lambda: git_blob_id(path))):
        seconds = timed(function, args.repeats)
        print(f"  {name:<33} {seconds:6.3f} s  {args.size / seconds:7.0f} MB/s")

    print(f"a whole transfer of {args.size} MB over 127.0.0.1, sha256 checked (median of {args.repeats}):")
    for name, make in (("pooch HTTPDownloader (1 KiB chunks)", lambda target: None),
                       ("pooch HTTPDownloader (1 MiB chunks)", lambda target: pooch.HTTPDownloader(chunk_size=1 << 20)),
                       ("vigen ResumingDownloader", lambda target: ResumingDownloader(target, size=len(data)))):
        def transfer(make=make) -> None:
            target = Path(tempfile.mkdtemp(dir=work)) / "file.bin"
            pooch.retrieve(f"{url}/file.bin", known_hash=f"sha256:{sha256}", fname=target.name, path=target.parent,
                           downloader=make(target), progressbar=False)
        seconds = timed(transfer, args.repeats)
        print(f"  {name:<35} {seconds:6.3f} s  {args.size / seconds:7.0f} MB/s")

    print("a transfer cut at half its bytes, then run again: bytes the second run transfers")
    for name, make in (("pooch HTTPDownloader", lambda target: None),
                       ("vigen ResumingDownloader", lambda target: ResumingDownloader(target, size=len(data)))):
        target = Path(tempfile.mkdtemp(dir=work)) / "file.bin"
        cut.add("/file.bin")
        try:
            pooch.retrieve(f"{url}/file.bin", known_hash=f"sha256:{sha256}", fname=target.name, path=target.parent,
                           downloader=make(target), progressbar=False)
        except Exception as error:  # the cut
            cut_error = first_line(error)
        sent[0] = 0
        pooch.retrieve(f"{url}/file.bin", known_hash=f"sha256:{sha256}", fname=target.name, path=target.parent,
                       downloader=make(target), progressbar=False)
        print(f"  {name:<35} {sent[0] / len(data):6.0%} of the file  (the cut: {cut_error[:100]})")

    print("messages:")
    target = Path(tempfile.mkdtemp(dir=work)) / "missing.bin"
    try:
        pooch.retrieve(f"{url}/missing.bin", known_hash=None, fname=target.name, path=target.parent, progressbar=False)
    except Exception as error:
        print(f"  pooch 404:    {first_line(error)}")
    target = Path(tempfile.mkdtemp(dir=work)) / "file.bin"
    try:
        pooch.retrieve(f"{url}/file.bin", known_hash="sha256:" + "0" * 64, fname=target.name, path=target.parent,
                       progressbar=False)
    except Exception as error:
        print(f"  pooch sha256: {first_line(error)}")
    for pin, what in (("missing.bin", "404:   "), ("file.bin", "sha256:")):
        record = DataSet("bench", "a file", "CC0", "this benchmark", url_template=f"{url}/{{path}}",
                         files=(PinnedFile(pin, None, None, sha256="0" * 64),))
        try:
            fetch(record, root=Path(tempfile.mkdtemp(dir=work)))
        except Exception as error:
            lines = str(error).splitlines()
            print(f"  vigen {what} {type(error).__name__}: {lines[1].strip()[:300]} / {lines[2][:200]}")
    target = Path(tempfile.mkdtemp(dir=work)) / "file.bin"
    target.write_bytes(b"a file of the user's under the data set's name")
    pooch.retrieve(f"{url}/file.bin", known_hash=f"sha256:{sha256}", fname=target.name, path=target.parent, progressbar=False)
    print(f"  pooch, a wrong file already under the target's name: {'replaced' if target.read_bytes() == data else 'kept'} "
          "(vigen.datasets.fetch leaves it and names it)")


if __name__ == "__main__":
    main()
