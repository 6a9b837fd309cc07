"""Cut a virtual environment down to what runs: the Dockerfile's builder stage calls it.

``python slim_venv.py /opt/venv`` removes, under the environment:

- C/C++ headers (``include/`` directories holding no Python module), static (``*.a``) and libtool
  (``*.la``) libraries, CMake and pkg-config files: they only serve to build extensions;
- the test suites that packages ship (``tests/`` directories inside a package, e.g. numpy's and
  scipy's): never imported by a running service;
- duplicate bytes: a wheel cannot hold symlinks, so ``libfoo.so``, ``libfoo.so.3`` and
  ``libfoo.so.3.7`` arrive as three identical files; every identical copy in one directory becomes
  a relative symlink to one of them (the dynamic loader follows symlinks).

It prints the megabytes each step freed. Standard library only (it runs in the build stage).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from collections import defaultdict
from pathlib import Path

MIN_DEDUP_BYTES = 4096
"""Smaller files are not worth a symlink."""


def _has_python(directory: Path) -> bool:
    return any(p.suffix in (".py", ".pyi") for p in directory.rglob("*"))


def _size(path: Path) -> int:
    if path.is_symlink() or not path.exists():
        return 0
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink())


def _remove(path: Path) -> int:
    size = _size(path)
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()
    return size


def build_only(root: Path) -> int:
    """Headers, static and libtool libraries, CMake and pkg-config files; bytes freed."""
    freed = 0
    for directory in sorted(root.rglob("*"), key=lambda p: len(p.parts)):
        if not directory.is_dir() or directory.is_symlink() or not directory.exists():
            continue
        if directory.name in ("include", "cmake", "pkgconfig") and not _has_python(directory):
            freed += _remove(directory)
    for pattern in ("*.a", "*.la"):
        for path in list(root.rglob(pattern)):
            if path.is_file() or path.is_symlink():
                freed += _remove(path)
    return freed


def package_tests(root: Path) -> int:
    """``tests/`` directories of packages (their parent is a package); bytes freed."""
    freed = 0
    for directory in sorted(root.rglob("tests"), key=lambda p: len(p.parts)):
        if (
            directory.exists()
            and directory.is_dir()
            and not directory.is_symlink()
            and (directory.parent / "__init__.py").is_file()
            and "site-packages" in directory.parts
        ):
            freed += _remove(directory)
    return freed


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def duplicates(root: Path) -> int:
    """Identical regular files in one directory -> symlinks to the first (by name); bytes freed."""
    by_size: dict[tuple[Path, int], list[Path]] = defaultdict(list)
    for path in root.rglob("*"):
        if path.is_file() and not path.is_symlink():
            size = path.stat().st_size
            if size >= MIN_DEDUP_BYTES:
                by_size[(path.parent, size)].append(path)
    freed = 0
    for (_, size), paths in by_size.items():
        if len(paths) < 2:
            continue
        by_digest: dict[str, list[Path]] = defaultdict(list)
        for path in paths:
            by_digest[_digest(path)].append(path)
        for same in by_digest.values():
            keep, *copies = sorted(same, key=lambda p: p.name)
            for copy in copies:
                mode = copy.stat().st_mode
                copy.unlink()
                copy.symlink_to(keep.name)
                os.chmod(keep, keep.stat().st_mode | (mode & 0o111))
                freed += size
    return freed


def main(argv: list[str]) -> int:
    if len(argv) != 2 or not Path(argv[1]).is_dir():
        print("usage: python slim_venv.py VENV_DIR", file=sys.stderr)
        return 2
    root = Path(argv[1])
    before = _size(root)
    for step in (build_only, package_tests, duplicates):
        print(f"slim_venv: {step.__name__}: {step(root) / 2**20:.0f} MB freed")
    print(f"slim_venv: {before / 2**20:.0f} MB -> {_size(root) / 2**20:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
