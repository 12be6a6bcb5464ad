"""Stop signals held back around a write that must not be cut."""

import os
import signal
import threading

from sassi_bench._shared.signals import deferred_stop_signals


def test_a_stop_signal_reaches_its_handler_only_after_the_block():
    seen: list[str] = []
    previous = signal.signal(signal.SIGTERM, lambda n, f: seen.append("handler"))
    try:
        with deferred_stop_signals():
            os.kill(os.getpid(), signal.SIGTERM)
            seen.append("block ends")
        assert seen == ["block ends", "handler"]
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL  # put back
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_nothing_is_delivered_without_a_signal_and_threads_are_left_alone():
    handler = signal.getsignal(signal.SIGINT)
    with deferred_stop_signals():
        pass
    assert signal.getsignal(signal.SIGINT) is handler
    errors: list[BaseException] = []

    def in_thread() -> None:
        try:
            with deferred_stop_signals():
                pass
        except BaseException as exc:  # signal.signal would raise outside the main thread
            errors.append(exc)

    thread = threading.Thread(target=in_thread)
    thread.start()
    thread.join()
    assert errors == []
