import os
import stat

import pytest

from gcs.atomic import staged_outputs, write_json_atomic, write_text_atomic


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_atomic_write_replaces_whole_file_with_ordinary_permissions(tmp_path):
    path = tmp_path / "sub" / "a.json"
    write_json_atomic(path, {"a": 1})
    write_text_atomic(path, "second\n")
    assert path.read_text() == "second\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~_umask()
    assert [p.name for p in path.parent.iterdir()] == ["a.json"]


def test_staged_outputs_publish_all_or_nothing(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a")
    with pytest.raises(RuntimeError):
        with staged_outputs([a, b]) as staged:
            staged[a].write_text("new a")
            raise RuntimeError("failed before b was written")
    assert a.read_text() == "old a" and not b.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]
    with staged_outputs([a, b]) as staged:
        staged[a].write_text("new a")
        staged[b].write_text("new b")
    assert (a.read_text(), b.read_text()) == ("new a", "new b")
    assert stat.S_IMODE(b.stat().st_mode) == 0o666 & ~_umask()
