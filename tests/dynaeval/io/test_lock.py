"""``dynaeval.io.lock.hold_folder``: one writer per output folder."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys

import pytest

from dynaeval.errors import InputError
from dynaeval.io.lock import LOCK_NAME, hold_folder


def _gone_pid() -> int:
    """The id of a process that has ended (and been reaped)."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def _lock(folder, pid, host=None) -> None:
    (folder / LOCK_NAME).write_text(json.dumps(
        {"pid": pid, "host": host or socket.gethostname(), "started": "2026-12-03T10:00:00"}))


def test_the_lock_is_there_while_held_and_gone_after_however_the_block_ends(tmp_path):
    with hold_folder(tmp_path):
        holder = json.loads((tmp_path / LOCK_NAME).read_text())
        assert holder["pid"] == os.getpid() and holder["host"] == socket.gethostname()
    assert not (tmp_path / LOCK_NAME).exists()
    with pytest.raises(KeyboardInterrupt), hold_folder(tmp_path):
        raise KeyboardInterrupt
    assert not (tmp_path / LOCK_NAME).exists()


def test_a_second_holder_is_refused_naming_the_folder_the_holder_and_the_fix(tmp_path):
    with hold_folder(tmp_path), pytest.raises(InputError) as err, hold_folder(tmp_path, "suite output folder"):
        pass
    text = str(err.value)
    assert f"suite output folder {tmp_path} is in use" in text
    assert f"process {os.getpid()} on {socket.gethostname()}" in text
    assert "pass another -o" in text and f"delete {tmp_path / LOCK_NAME}" in text


def test_a_lock_of_a_process_that_has_ended_is_taken_over(tmp_path):
    _lock(tmp_path, _gone_pid())
    with hold_folder(tmp_path):
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    assert not (tmp_path / LOCK_NAME).exists()


@pytest.mark.parametrize("content", ["", "{", "[]", '{"pid": "7", "host": "h"}'])
def test_an_unreadable_lock_is_refused_not_guessed(tmp_path, content):
    (tmp_path / LOCK_NAME).write_text(content)
    with pytest.raises(InputError, match="cannot be read"), hold_folder(tmp_path):
        pass
    assert (tmp_path / LOCK_NAME).read_text() == content


def test_a_lock_from_another_host_is_not_taken_over(tmp_path):
    _lock(tmp_path, _gone_pid(), host="another-host.invalid")
    with pytest.raises(InputError, match="on another-host.invalid"), hold_folder(tmp_path):
        pass
