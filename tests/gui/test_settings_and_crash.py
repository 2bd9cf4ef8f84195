"""Settings persistence, recent files, and the global exception hook."""

from __future__ import annotations

import sys
import threading

from dreamprint_gui.gui.crash import install_exception_hook, log_file, short_message
from dreamprint_gui.gui.settings import MAX_RECENT, AppSettings


def test_recent_files_persist_in_order(tmp_path):
    s = AppSettings()
    files = []
    for i in range(MAX_RECENT + 3):
        f = tmp_path / f"v{i}.vti"
        f.write_text("x")
        files.append(str(f.resolve()))
        s.add_recent(f)
    s.add_recent(files[-5])  # reopening moves it to the top, without a duplicate
    s.sync()
    again = AppSettings().recent_files()
    assert again[0] == files[-5]
    assert len(again) == MAX_RECENT
    assert len(set(again)) == MAX_RECENT
    assert files[0] not in again


def test_single_recent_file_and_values():
    s = AppSettings()
    s.add_recent("demo")
    s.set("export/seed", 7)
    s.sync()
    t = AppSettings()
    assert t.recent_files() == ["demo"]
    assert t.get("export/seed", 0, int) == 7


def test_exception_hook_logs_and_reports(qtbot, monkeypatch):
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)  # restored after the test
    monkeypatch.setattr(threading, "excepthook", threading.excepthook)
    reporter = install_exception_hook(interactive=False)
    try:
        raise ValueError("something odd\nsecond line")
    except ValueError:
        sys.excepthook(*sys.exc_info())
    qtbot.waitUntil(lambda: "ValueError: something odd" in reporter.shown, timeout=2000)
    text = log_file().read_text()
    assert "Traceback" in text and "second line" in text

    def boom():
        raise RuntimeError("from a thread")

    th = threading.Thread(target=boom)
    th.start()
    th.join()
    qtbot.waitUntil(lambda: "RuntimeError: from a thread" in reporter.shown, timeout=2000)


def test_short_message_of_dreamprint_error():
    from dreamprint_gui.core.errors import DreamPrintError

    assert short_message(DreamPrintError("bad header", "a.vdb", 3)) == "a.vdb:3: bad header"
