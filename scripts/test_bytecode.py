"""Write the tests' byte code once, at set-up: pytest's cache of the test modules with their
asserts rewritten, and the helper modules' ordinary byte code.

Where PYTHONDONTWRITEBYTECODE is set (this machine and its CI), pytest caches no rewritten
module, so each of `make test`'s four workers parsed, rewrote and compiled every test module
again: four workers started and collected in 13-14 s and 24-26 CPU s, against 6-7 s and
10-11 CPU s with the cache in place. pytest still reads a cache it finds: its pycs are
checked against a hash of the source, so a stale one is never used.

The rewriting is pytest's own (``rewrite_asserts``; the project sets no
``enable_assertion_pass_hook``, the one option it reads), but it and the cache's format are
private to pytest: if the pinned pytest changes them, this writes nothing and says so, and
the tests run as before, only slower to start.

    python scripts/test_bytecode.py test
"""

from __future__ import annotations

import ast
import compileall
import importlib.util
import os
import sys
from pathlib import Path


def rewritten(folder: Path) -> list[Path]:
    """The modules pytest rewrites there: its default ``python_files`` and the conftest."""
    return sorted(folder.glob("test_*.py")) + sorted(folder.glob("conftest.py"))


def write_rewritten(path: Path, rewrite) -> bool:
    """pytest's cached pyc of ``path``; False if it was current already."""
    source = path.read_bytes()
    source_hash = importlib.util.source_hash(source)
    pyc = rewrite.get_cache_dir(path) / (path.name[:-3] + rewrite.PYC_TAIL)
    if rewrite._read_pyc(path, pyc) is not None:  # pytest's own check: current, it takes it
        return False
    tree = ast.parse(source, filename=str(path))
    rewrite.rewrite_asserts(tree, source, str(path), None)
    code = compile(tree, str(path), "exec", dont_inherit=True)
    pyc.parent.mkdir(parents=True, exist_ok=True)
    partial = pyc.with_name(f"{pyc.name}.{os.getpid()}")  # whole or not at all, as pytest writes it
    with open(partial, "wb") as file:
        rewrite._write_pyc_fp(file, source_hash, code)
    os.replace(partial, pyc)
    return True


def main(argv: list[str]) -> int:
    if len(argv) != 1 or not Path(argv[0]).is_dir():
        print("usage: test_bytecode.py TEST_FOLDER", file=sys.stderr)
        return 2
    folder = Path(argv[0]).absolute()  # as pytest names it (a prefix cache mirrors the path)
    tests = rewritten(folder)
    for helper in sorted(set(folder.glob("*.py")) - set(tests)):
        compileall.compile_file(str(helper), quiet=1)  # left as it is where up to date
    try:
        from _pytest.assertion import rewrite

        for name in ("rewrite_asserts", "get_cache_dir", "PYC_TAIL", "_read_pyc", "_write_pyc_fp"):
            getattr(rewrite, name)
    except (ImportError, AttributeError) as exc:
        print(f"test_bytecode: pytest's rewriting has moved ({exc}); its cache is left to pytest", file=sys.stderr)
        return 0
    try:
        written = sum(write_rewritten(path, rewrite) for path in tests)
    except Exception as exc:  # noqa: BLE001 -- a changed private API: only the cache is lost
        print(f"test_bytecode: pytest's rewriting failed here ({exc!r}); its cache is left to pytest",
              file=sys.stderr)
        return 0
    print(f"test_bytecode: {written} of {len(tests)} test modules rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
