"""Fixtures shared by the interop tests."""
import os

import pytest


@pytest.fixture
def not_regular_files(tmp_path):
    """Paths that are not regular files, each with the words a refusal names it by: a FIFO (whose
    blocking open waits for a writer), a folder and a device that never ends."""
    fifo = tmp_path / "pipe.exr"
    os.mkfifo(fifo)
    folder = tmp_path / "folder.exr"
    folder.mkdir()
    return [(str(fifo), "a FIFO (named pipe)"), (str(folder), "a directory"), ("/dev/zero", "a character device")]
