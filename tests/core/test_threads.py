"""DaemonCall: one call on a daemon thread, its result or error handed back to the caller."""

import threading

import pytest

from dreamprint_gui.core.threads import DaemonCall


def test_result_error_and_thread():
    seen = {}

    def fn():
        seen["thread"] = threading.current_thread()
        return 7

    call = DaemonCall(fn, "t-ok")
    assert call.result() == 7
    assert seen["thread"] is not threading.main_thread()
    assert seen["thread"].daemon and seen["thread"].name == "t-ok"
    assert not call.is_alive()

    def broken():
        raise KeyboardInterrupt  # a BaseException too comes back to the caller

    with pytest.raises(KeyboardInterrupt):
        DaemonCall(broken, "t-bad").result()
