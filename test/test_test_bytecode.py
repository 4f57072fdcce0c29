"""scripts/test_bytecode.py, which `make setup` runs: the cache it writes is the one pytest
would write (and reads), and it rewrites only what changed."""

import importlib.util
from pathlib import Path

import pytest
from conftest import load_script

try:  # pytest's private rewriting, which the script uses: gone, the script writes nothing
    from _pytest.assertion.rewrite import PYC_TAIL, _read_pyc, _rewrite_test, get_cache_dir
except ImportError:
    pytest.skip("pytest's assertion rewriting has moved", allow_module_level=True)

MODULES = {"test_sample.py": "def test_sum():\n    total = 1 + 1\n    assert total == 2, total\n",
           "conftest.py": "def helper_value():\n    assert True\n    return 3\n",
           "harness.py": "VALUE = 1\n"}


def test_the_cache_is_pytests_own_and_only_what_changed_is_rewritten(tmp_path, request, capsys):
    script = load_script("test_bytecode")
    for name, text in MODULES.items():
        (tmp_path / name).write_text(text)
    assert script.main([str(tmp_path)]) == 0
    assert "2 of 2 test modules rewritten" in capsys.readouterr().out
    cache = get_cache_dir(tmp_path / "conftest.py")  # __pycache__, or under PYTHONPYCACHEPREFIX
    for name in ("test_sample.py", "conftest.py"):
        code = _read_pyc(tmp_path / name, cache / (name[:-3] + PYC_TAIL))
        assert code is not None, name  # pytest takes it
        assert code == _rewrite_test(tmp_path / name, request.config)[1]  # and it is what pytest makes
    assert Path(importlib.util.cache_from_source(str(tmp_path / "harness.py"))).exists()  # the helper's own

    assert script.main([str(tmp_path)]) == 0
    assert "0 of 2 test modules rewritten" in capsys.readouterr().out
    (tmp_path / "test_sample.py").write_text(MODULES["test_sample.py"].replace("2, total", "2"))
    assert script.main([str(tmp_path)]) == 0
    assert "1 of 2 test modules rewritten" in capsys.readouterr().out
    assert _read_pyc(tmp_path / "test_sample.py", cache / ("test_sample" + PYC_TAIL)) == \
        _rewrite_test(tmp_path / "test_sample.py", request.config)[1]


def test_a_missing_folder_is_a_usage_error(tmp_path, capsys):
    assert load_script("test_bytecode").main([str(tmp_path / "absent")]) == 2
    assert "usage" in capsys.readouterr().err
