"""``python -m vigen.datasets``: list, fetch, verify and locate the benchmarks' named data sets.

Commands (each takes ``--root`` to use another cache folder than ``$VIGEN_DATA`` / ``~/.cache/vigen``)::

    python -m vigen.datasets list                     name, what, files, size, license, fetched or not and where
    python -m vigen.datasets fetch NAME [--part P] [--mirror M] [--wait S]
    python -m vigen.datasets verify [NAME]            hash every fetched file; exit 1 on any mismatch
    python -m vigen.datasets path NAME [--part P]     print the folder; exit 1 when it is not fetched

Progress goes to stderr; results (list, verify reports, paths) to stdout. Exit status: 0 done,
1 a data error (one ``error:`` message on stderr that ends with the fix), 2 a usage error (unknown
data set or part), 130 interrupted (a fetch resumes where it stopped).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from typing import TextIO

from vigen.datasets.fetch import Progress, fetch, fetch_command
from vigen.datasets.records import DATASETS, DataError, DataSet, UnknownDataSetError, cache_root, get_dataset
from vigen.datasets.verify import locate, status, verify


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``) and return its exit status.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets.__main__ import main
        >>> main(["path", "dmcgb-videos", "--part", "video_hard", "--root", tempfile.mkdtemp()])  # not fetched there
        1
    """
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.run(args)
    except BrokenPipeError:  # the reader of stdout went away (e.g. `| head`): stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print("error: interrupted. Fix: re-run the same command; a fetch resumes the files it had begun (their .part "
              "files are kept).", file=sys.stderr)
        return 130
    except UnknownDataSetError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except DataError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except OSError as error:  # the file system under --root, outside a fetch (which names its own errors)
        root = cache_root(getattr(args, "root", None))
        print(f"error: cannot read the data cache {root}: {error}. Fix: give a folder you can read and write with --root DIR "
              "(or $VIGEN_DATA).", file=sys.stderr)
        return 1


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m vigen.datasets", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=f"data sets: {', '.join(DATASETS)}. See docs/data.md.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="{list,fetch,verify,path}")

    def command(name: str, run, help: str) -> argparse.ArgumentParser:
        sub = commands.add_parser(name, help=help, description=help)
        sub.add_argument("--root", help="cache folder (default: $VIGEN_DATA, else $XDG_CACHE_HOME/vigen or ~/.cache/vigen)")
        sub.set_defaults(run=run)
        return sub

    command("list", _list, "list the data sets: what, files, size, license, fetched or not and where")
    sub = command("fetch", _fetch, "fetch a data set (or one part) into the cache, checking every file")
    sub.add_argument("name")
    sub.add_argument("--part", help="fetch only this part (e.g. video_hard)")
    sub.add_argument("--mirror", help="http(s) URL or folder laid out as <mirror>/<name>/<file> (default: $VIGEN_DATA_MIRROR)")
    sub.add_argument("--wait", type=float, metavar="SECONDS",
                     help="while another process fetches this data set, wait at most this long (default: until it ends)")
    sub = command("verify", _verify, "hash every fetched file and compare with its pinned or recorded id")
    sub.add_argument("name", nargs="?", help="one data set (default: all)")
    sub = command("path", _path, "print the folder of a fetched data set or part (exit 1 when not fetched)")
    sub.add_argument("name")
    sub.add_argument("--part")
    return parser


def _list(args: argparse.Namespace) -> int:
    for dataset in DATASETS.values():
        print(f"{dataset.name}  {_files_and_size(dataset)}  license: {dataset.license}")
        print(f"    {dataset.title}")
        print(f"    source: {dataset.source}")
        for part in status(dataset, args.root):
            label = part.part or "files"
            if part.expected is None:
                print(f"    {label}: not fetched ({part.folder})")
            else:
                state = "fetched" if part.complete else ("not fetched" if part.present == 0 else "partly fetched")
                print(f"    {label}: {state}, {part.present}/{part.expected} files in {part.folder}")
    return 0


def _fetch(args: argparse.Namespace) -> int:
    printer = _ProgressPrinter(sys.stderr)
    start = time.monotonic()
    try:
        folder = fetch(args.name, part=args.part, root=args.root, mirror=args.mirror, progress=printer, wait=args.wait)
    finally:
        printer.close()
    print(f"fetched {args.name}{f' part {args.part}' if args.part else ''} in {time.monotonic() - start:.1f} s "
          f"({printer.downloaded} downloaded, {printer.present} already present)", file=sys.stderr)
    print(folder)
    return 0


def _verify(args: argparse.Namespace) -> int:
    names = [get_dataset(args.name).name] if args.name else list(DATASETS)
    failed = []
    for name in names:
        report = verify(name, args.root)
        print(report)
        if not report.ok:
            failed.append(name)
    if failed:
        print(f"error: {', '.join(failed)}: files that are not the pinned ones (MISMATCH above). Fix: move them aside, then "
              f"re-run {' and '.join(f'`{fetch_command(name, root=args.root)}`' for name in failed)}.", file=sys.stderr)
    return 1 if failed else 0


def _path(args: argparse.Namespace) -> int:
    dataset = get_dataset(args.name)
    folder = locate(dataset, args.part, args.root)
    if folder is not None:
        print(folder)
        return 0
    parts = [part for part in status(dataset, args.root) if args.part is None or part.part == args.part]
    have = ", ".join(f"{p.part or 'files'} {p.present}/{p.expected if p.expected is not None else '?'}" for p in parts)
    scope = f"{dataset.name} part {args.part}" if args.part else dataset.name
    print(f"{scope} is not (fully) fetched in {parts[0].folder.parent if args.part else parts[0].folder} ({have} files present). "
          f"Fetch it with: {fetch_command(dataset.name, args.part, root=args.root)}", file=sys.stderr)
    return 1


def _files_and_size(dataset: DataSet) -> str:
    if dataset.archive is not None:
        return f"1 zip archive ({dataset.archive.size / 1e6:.1f} MB, sha256 pinned), extracted"
    sizes = [pinned.size for pinned in dataset.files if pinned.size is not None]
    unknown = len(dataset.files) - len(sizes)
    text = f"{len(dataset.files)} files, {sum(sizes) / 1e6:.1f} MB"
    return text + (f" + {unknown} files of unrecorded size" if unknown else "")


class _ProgressPrinter:
    """Prints a fetch's progress events to a stream: a line per file, and a live byte count on a terminal."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.live = stream.isatty()
        self.downloaded = 0
        self.present = 0
        self._last = 0.0
        self._open_line = False

    def __call__(self, event: Progress) -> None:
        if event.stage == "wait":
            self._write(f"{event.dataset}: {event.message}")
            return
        prefix = f"[{event.index:>{len(str(event.count))}}/{event.count}] {event.dataset}/{event.file}"
        if event.stage in ("download", "resume"):
            if event.message:
                self._write(f"{prefix}: {event.message}")
            elif self.live and time.monotonic() - self._last > 0.2:
                total = f"/{event.total / 1e6:.1f}" if event.total else ""
                self._write(f"\r{prefix}: {event.done / 1e6:.1f}{total} MB", end="")
                self._last = time.monotonic()
            return
        if event.stage == "present":
            self.present += 1
            text = f"already present, checked{f' ({event.message})' if event.message else ''}"
        elif event.stage == "done":
            self.downloaded += 1
            text = event.message or f"downloaded and checked ({(event.total or 0) / 1e6:.2f} MB)"
        elif event.stage == "failed":
            text = "FAILED: " + event.message.partition(" Fix: ")[0]
        else:
            text = event.message or event.stage
        self._write(f"{prefix}: {text}")

    def _write(self, text: str, end: str = "\n") -> None:
        if self._open_line and not text.startswith("\r"):
            self.stream.write("\n")
        self.stream.write(text + end)
        self.stream.flush()
        self._open_line = end == ""

    def close(self) -> None:
        if self._open_line:
            self.stream.write("\n")
            self._open_line = False


if __name__ == "__main__":
    sys.exit(main())
